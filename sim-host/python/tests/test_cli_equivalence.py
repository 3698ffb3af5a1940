"""A run from Python equals `sim-host run` of the same file: the same summary (minus the
wall-clock fields) and the same columns bit for bit, for every shipped scenario."""

import warnings

import numpy as np
import pytest

import acs
from conftest import REPO, SCENARIOS, cli_run_finish, cli_run_start, require_qemu_firmware, same_bits, without_wall_clock


def test_every_shipped_scenario_is_found():
    assert len(SCENARIOS) >= 30


@pytest.mark.parametrize("path", SCENARIOS, ids=[str(p.relative_to(REPO / "scenarios")) for p in SCENARIOS])
def test_python_run_equals_cli_run(path, sim_host, tmp_path):
    # Both at once: the Python run releases the interpreter's lock, the CLI is a process.
    cli = cli_run_start(sim_host, path, tmp_path / "out")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", acs.RunStatusWarning)
        r = acs.run(acs.Scenario.load(path), link="in-process")
    status, cli_summary, (cli_names, cli_cols) = cli_run_finish(cli, tmp_path / "out")
    assert without_wall_clock(r.summary) == without_wall_clock(cli_summary)
    assert r.ok == (status == 0)
    assert r.column_names == cli_names
    for name in cli_names:
        col = r.columns[name]
        assert col.dtype == np.float64 and col.flags["C_CONTIGUOUS"]
        assert same_bits(col, cli_cols[name]), f"{path.name}: column {name} differs"


def test_python_run_over_qemu_equals_cli_run_over_qemu(sim_host, tmp_path):
    """Processor-in-the-loop from Python: the firmware under QEMU, as `sim-host run --link qemu`.
    The commands are the same bits; a step's instruction count is not (two QEMU runs differ
    by a few instructions per step: when each frame's bytes arrive is host timing)."""
    require_qemu_firmware("test_python_run_over_qemu_equals_cli_run_over_qemu")
    sc = acs.Scenario.load(REPO / "scenarios/paper000/test1.toml")
    sc["duration_s"] = 5.0
    path = tmp_path / "short.toml"
    path.write_text(sc.to_toml())
    status, cli_summary, (names, cols) = cli_run_finish(cli_run_start(sim_host, path, tmp_path / "out", link="qemu"), tmp_path / "out")
    r = acs.run(sc, link="qemu")
    assert r.ok and status == 0 and r.summary["link"] == cli_summary["link"]
    cost = lambda d: {k: v for k, v in without_wall_clock(d).items() if "instructions" not in k}
    assert cost(r.summary) == cost(cli_summary)
    assert all(same_bits(r.columns[n], cols[n]) for n in names if n != "step_cost_insns")
