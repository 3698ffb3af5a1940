"""Monte Carlo campaigns from Python: the same files and results as
``sim-host campaign plan / run / merge`` (docs/campaigns.md).

    m = acs.campaign.plan("campaigns/paper000-test3-dispersed.toml", "out/c3", runs=50)
    acs.campaign.run("out/c3", jobs=2)
    result = acs.campaign.merge("out/c3")      # campaign.json as a dict, plus "passed"
"""

from __future__ import annotations

import os
from typing import Any, Dict, Optional, Union

from . import _core

PathLike = Union[str, "os.PathLike[str]"]


def plan(spec: PathLike, out: PathLike, runs: Optional[int] = None) -> Dict[str, Any]:
    """Plans the campaign file ``spec`` into the directory ``out`` (``runs`` overrides its
    run count); returns ``manifest.json`` as a dict. Raises ``acs.CampaignError``."""
    return _core.campaign_plan(spec, out, runs)


def run(out: PathLike, jobs: Optional[int] = None, shard: Optional[str] = None, progress: bool = False) -> Dict[str, int]:
    """Flies the pending runs of ``out`` (``shard="K/S"``: one shard) on ``jobs`` threads
    (default: every core), resumable; returns what the shard did (``ran``, ``ok``,
    ``errors``, ...). Ctrl-C stops it within a fraction of a second (``KeyboardInterrupt``):
    the runs in flight stop and write no result, so the next ``run`` flies them again."""
    return _core.campaign_run(out, jobs, shard, progress)


def merge(out: PathLike, plots: bool = True) -> Dict[str, Any]:
    """Merges the results of ``out`` into ``campaign.json``, ``report.md`` and ``plots/``;
    returns ``campaign.json`` as a dict plus ``passed`` (the verdict behind the CLI's exit
    status: a failed campaign is returned, not raised)."""
    return _core.campaign_merge(out, plots)
