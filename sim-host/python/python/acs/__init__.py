"""acs — the attitude-control simulator and its flight software, from Python.

    import acs
    sc = acs.Scenario.load("scenarios/paper000/test1.toml")
    sc["controller.wn_rad_s"] = 0.8          # the key paths campaigns use
    r = acs.run(sc)                           # in-process (SIL); link="qemu" for PIL
    r.ok, r.summary["final_error_deg"], r.columns["t"]
    df = r.to_pandas()
    r.view("replay.html")                     # the run in 3D, in a browser

The simulator is the Rust library `sim-core`; this package is a thin layer over its
native module `acs._core`. Guide: docs/python.md.
"""

from __future__ import annotations

import operator
import os
import warnings
from typing import Any, Callable, Dict, List, Optional, Union

import numpy as np

from . import _core
from ._core import (
    AcsError,
    CampaignError,
    FrameError,
    Fsw,
    InternalError,
    RunError,
    Scenario,
    ScenarioError,
    ScenarioKeyError,
    ScenarioTypeError,
    empty_frame,
    frame_to_bytes,
    record_frames,
)
from . import campaign

PathLike = Union[str, "os.PathLike[str]"]

__version__ = _core.__version__
PROTOCOL_VERSION = _core.PROTOCOL_VERSION

__all__ = [
    "AcsError",
    "CampaignError",
    "FrameError",
    "Fsw",
    "InternalError",
    "RunError",
    "RunResult",
    "RunStatusWarning",
    "RunFailed",
    "Scenario",
    "ScenarioError",
    "ScenarioKeyError",
    "ScenarioTypeError",
    "campaign",
    "empty_frame",
    "frame_to_bytes",
    "record_frames",
    "run",
    "view",
]


class RunStatusWarning(UserWarning):
    """A run completed but its ``run_status`` is not ``"ok"`` (diverged, every step refused,
    link anomaly): its result must not be taken as a success. See ``RunResult.ok``."""


class RunFailed(AcsError):
    """Raised by ``RunResult.raise_for_status()`` for a run whose ``run_status`` is not
    ``"ok"``; ``.result`` holds the ``RunResult``."""

    def __init__(self, message: str, result: "RunResult") -> None:
        super().__init__(message)
        self.result = result


class RunResult:
    """A run in memory: ``summary`` (the dict of ``summary.json``), ``columns`` (name →
    numpy float64 array, the rows of ``timeseries.csv``), ``column_names`` (their order).

    ``ok`` is False when the run diverged, the flight code refused every step, or a link
    anomaly may have changed the result (``summary["run_status"]``, ``summary["failure"]``);
    ``acs.run`` then also warns (``RunStatusWarning``), and ``raise_for_status()`` raises.
    """

    __slots__ = ("summary", "columns", "column_names", "scenario_toml")

    def __init__(
        self,
        summary: Dict[str, Any],
        column_names: List[str],
        columns: Dict[str, np.ndarray],
        scenario_toml: Optional[str] = None,
    ) -> None:
        self.summary = summary
        self.column_names = column_names
        self.columns = columns
        #: The TOML of the scenario as it flew (``acs.run`` keeps it for ``view``).
        self.scenario_toml = scenario_toml

    def view(self, path: PathLike) -> str:
        """Writes the run's 3D replay (one self-contained HTML page, no network; the page
        ``sim-host view`` writes, docs/viewer.md) to ``path`` and returns the path. Open it in
        a browser. Needs the viewer bundle (``scripts/setup.sh``)."""
        if self.scenario_toml is None:
            raise RunError("this RunResult has no scenario (acs.run keeps it): use acs.view(run_dir) on a run directory")
        return _core.view_result(self.summary, self.column_names, self.columns, self.scenario_toml, os.fspath(path))

    @property
    def status(self) -> str:
        """``summary["run_status"]``: ``"ok"``, ``"diverged"``, ``"all_refused"``, ``"link_anomaly"``,
        ``"samples_dropped"``, ``"no_control"``, ``"keepout_violated"``, ``"timeline_missed"`` (a
        ``[[timeline]]`` segment missed), ``"fdir_false_alarm"`` (``[fdir]`` declared a healthy
        unit failed), ``"control_lost"`` (with ``[[faults]]``: control lost through the end of the
        run with no FDIR event), ``"recovery_failed"`` (with ``[[faults]]``: an FDIR event, yet
        control lost through the end and the flight not in a safe mode, or a degraded hold after
        it), ``"pointing_degraded"`` (with ``[[faults]]``: a hold off by more than its bound through
        the end with no FDIR event), ``"propellant_exceeded"`` (the thrusters used more than
        ``[performance] propellant_budget_kg``; a lost or degraded pointing wins over it) or
        ``"margins_failed"`` (a ``[margins]`` loop not stable and steady)."""
        return str(self.summary.get("run_status"))

    @property
    def ok(self) -> bool:
        """Whether the run completed with ``run_status == "ok"`` (the CLI's exit status 0)."""
        return self.status == "ok"

    def raise_for_status(self) -> "RunResult":
        """Raises ``acs.RunFailed`` unless ``ok``; returns ``self`` otherwise."""
        if not self.ok:
            raise RunFailed(_status_message(self.summary), self)
        return self

    def __len__(self) -> int:
        return len(self.columns[self.column_names[0]]) if self.column_names else 0

    def __repr__(self) -> str:
        return f"RunResult({self.summary.get('scenario')!r}, status={self.status!r}, rows={len(self)})"

    def to_pandas(self) -> Any:
        """The columns as a ``pandas.DataFrame`` (in column order; numpy arrays not copied
        where pandas can avoid it)."""
        try:
            import pandas as pd
        except ImportError as e:
            raise ImportError("RunResult.to_pandas() needs pandas: pip install pandas") from e
        return pd.DataFrame({n: self.columns[n] for n in self.column_names}, copy=False)

    def to_polars(self) -> Any:
        """The columns as a ``polars.DataFrame`` (in column order)."""
        try:
            import polars as pl
        except ImportError as e:
            raise ImportError("RunResult.to_polars() needs polars: pip install polars") from e
        return pl.DataFrame({n: self.columns[n] for n in self.column_names})


def _status_message(summary: Dict[str, Any]) -> str:
    return f"{summary.get('scenario')}: run_status {summary.get('run_status')!r}: {summary.get('failure')}"


def _progress_callback(progress: Union[None, bool, Callable[[int, int], Any]]) -> tuple:
    """(callback for the native run, a function that closes the bar)."""
    if progress is None or progress is False:
        return None, lambda: None
    if callable(progress) and progress is not True:
        return progress, lambda: None
    try:
        from tqdm.auto import tqdm
    except ImportError:
        tqdm = None
    if tqdm is None:
        import sys

        def text(done: int, total: int) -> None:
            sys.stderr.write(f"\r{done}/{total} steps")
            if done >= total:
                sys.stderr.write("\n")

        return text, lambda: None
    bar = tqdm(unit="step")

    def update(done: int, total: int) -> None:
        bar.total = total
        bar.update(done - bar.n)

    return update, bar.close


def run(
    scenario: Scenario,
    link: Optional[str] = None,
    progress: Union[None, bool, Callable[[int, int], Any]] = None,
    output_every: Optional[int] = None,
    firmware: Optional[str] = None,
) -> RunResult:
    """Flies ``scenario`` and returns its rows and summary in memory.

    ``link``: ``"in-process"`` (default, unless the scenario's ``link.kind`` says otherwise),
    ``"qemu"`` (the firmware under QEMU; ``firmware`` = the ELF), ``"tcp:HOST:PORT"``,
    ``"serial:DEV[@BAUD]"`` — as ``sim-host run --link``. ``progress``: ``True`` shows a bar
    (``tqdm.auto`` when installed: a widget in notebooks), a callable gets
    ``(steps_done, steps_total)``. ``output_every``: record every Nth control step
    (overrides ``timing.output_every``). Ctrl-C stops the run (``KeyboardInterrupt``)
    within a fraction of a second, in the run and in its ``[margins]`` measurement.
    The run flies a copy of ``scenario`` taken when it starts: changing the scenario
    meanwhile (from another thread) is allowed and does not change this run.

    A run that completes with ``run_status != "ok"`` is returned with ``ok == False`` and a
    ``RunStatusWarning``; errors before or during the run raise ``acs.RunError`` (or
    ``acs.ScenarioError`` for an invalid ``output_every``).
    """
    if not isinstance(scenario, Scenario):
        raise ScenarioTypeError(f"acs.run needs an acs.Scenario, not {type(scenario).__name__}")
    if output_every is not None:
        try:
            n = None if isinstance(output_every, bool) else operator.index(output_every)
        except TypeError:
            n = None
        if n is None or not 1 <= n < 2**32:
            raise ScenarioError(f"output_every: must be an integer in [1, 2**32) (got {output_every!r})")
        output_every = n
    if link is not None and not isinstance(link, str):
        raise RunError(f"link: a string such as \"in-process\" or \"tcp:HOST:PORT\" (got {type(link).__name__})")
    # The scenario as it flies (the run takes its own copy when it starts).
    scenario_toml = scenario.to_toml()
    callback, close = _progress_callback(progress)
    try:
        summary, names, columns = _core.run(scenario, link, callback, output_every, firmware)
    finally:
        close()
    result = RunResult(summary, names, columns, scenario_toml)
    if not result.ok:
        warnings.warn(_status_message(summary), RunStatusWarning, stacklevel=2)
    return result


def view(run_dir: PathLike, out: Optional[PathLike] = None) -> str:
    """Writes the 3D replay of a run directory (``sim-host run --out DIR``), as ``sim-host
    view DIR`` does: ``DIR/replay.html`` unless ``out``; returns the page's path."""
    return _core.view_run_dir(os.fspath(run_dir), None if out is None else os.fspath(out))
