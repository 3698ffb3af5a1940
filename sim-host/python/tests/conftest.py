"""Shared fixtures: the repository, the sim-host command (built if missing), scenarios."""

import json
import math
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[3]
TARGET = Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target"))
SCENARIOS = sorted(REPO.glob("scenarios/*/*.toml"))
# summary.json fields that time the host, not the simulation (scripts/golden.sh drops the same).
WALL_CLOCK = ("wall_time_s", "real_time_factor", "mean_step_us", "max_step_us", "allocation_us_per_call", "max_step_ticks")


@pytest.fixture(scope="session")
def sim_host() -> Path:
    exe = TARGET / "release" / "sim-host"
    if not exe.exists():
        subprocess.run(["cargo", "build", "--release", "-q", "-p", "sim-host"], cwd=REPO, check=True)
    return exe


FIRMWARE = REPO / "firmware/target/thumbv7em-none-eabihf/release/acs-firmware"


def require_tool(tool: str, found: bool, install: str, test: str) -> None:
    """The rule of sim-host/tests/support/require_tool.rs: a missing tool fails under CI
    and otherwise skips loudly, with a line in target/skipped-tests.log."""
    if found:
        return
    ci = os.environ.get("CI", "")
    if ci and ci not in ("0", "false"):
        pytest.fail(f"{tool} missing (CI): {install}")
    (TARGET).mkdir(parents=True, exist_ok=True)
    with open(TARGET / "skipped-tests.log", "a") as f:
        f.write(f"[{tool}] {test}: missing; {install}\n")
    pytest.skip(f"SKIPPED (tool missing): {tool}; {install}")


def require_qemu_firmware(test: str) -> None:
    require_tool("qemu-system-arm", shutil.which("qemu-system-arm") is not None, "scripts/setup.sh", test)
    require_tool("QEMU firmware ELF", FIRMWARE.exists(), "scripts/firmware.sh build", test)


def without_wall_clock(summary: dict) -> dict:
    return {k: v for k, v in summary.items() if k not in WALL_CLOCK}


def read_csv_columns(path: Path):
    """timeseries.csv as (names, {name: float64 array}); an empty field is NaN."""
    with open(path) as f:
        names = f.readline().rstrip("\n").split(",")
        rows = [[float(x) if x else math.nan for x in line.rstrip("\n").split(",")] for line in f]
    data = np.array(rows, dtype=np.float64).reshape(len(rows), len(names))
    return names, {n: data[:, i] for i, n in enumerate(names)}


def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    """Equal bit for bit where finite; non-finite in the same places (the CSV writes every
    non-finite value as an empty field, read back as NaN)."""
    if a.shape != b.shape:
        return False
    fa, fb = np.isfinite(a), np.isfinite(b)
    return bool(np.array_equal(fa, fb) and np.array_equal(a[fa].view(np.uint64), b[fb].view(np.uint64)))


def read_parquet_columns(path: Path):
    """timeseries.parquet read by pyarrow, as (names, {name: float64 array})."""
    import pyarrow.parquet as pq

    table = pq.read_table(path)
    return table.column_names, {n: table.column(n).to_numpy() for n in table.column_names}


def cli_run_start(
    sim_host: Path, scenario: Path, out: Path, *extra: str, link: str = "in-process", fmt: str = "parquet"
) -> subprocess.Popen:
    """Starts `sim-host run` into `out` (the caller flies the Python run meanwhile)."""
    cmd = [str(sim_host), "run", str(scenario), "--out", str(out), "--no-plots", "--quiet", "--link", link]
    cmd += ["--format", fmt]
    return subprocess.Popen(cmd + list(extra), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


def cli_run_finish(p: subprocess.Popen, out: Path):
    """(exit status, summary dict, columns) of a run started by `cli_run_start`: its
    timeseries.parquet read by pyarrow (its timeseries.csv when it wrote CSV)."""
    _, err = p.communicate()
    assert (out / "summary.json").exists(), err
    summary = json.loads((out / "summary.json").read_text())
    if (out / "timeseries.parquet").exists():
        return p.returncode, summary, read_parquet_columns(out / "timeseries.parquet")
    return p.returncode, summary, read_csv_columns(out / "timeseries.csv")


@pytest.fixture(autouse=True, scope="session")
def ctrl_c_reaches_python():
    """Ctrl-C as a terminal delivers it. A suite started in the background (`cmd &` in a
    script, nohup) inherits SIGINT ignored; Python then installs no handler, and
    `_thread.interrupt_main` (the in-process Ctrl-C tests) does nothing. Restore Python's
    own handler for the session."""
    import signal

    previous = signal.getsignal(signal.SIGINT)
    if previous is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)
