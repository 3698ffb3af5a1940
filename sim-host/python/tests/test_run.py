"""acs.run: result shape, pandas/polars/pyarrow views, progress, run status, Ctrl-C, GIL."""

import _thread
import threading
import time
import warnings

import numpy as np
import pytest

import acs
from conftest import REPO

TEST3 = REPO / "scenarios/paper000/test3.toml"


@pytest.fixture(scope="module")
def result():
    return acs.run(acs.Scenario.load(TEST3))


def test_result(result):
    assert result.ok and result.status == "ok" and result.raise_for_status() is result
    assert result.column_names[0] == "t_s"
    assert set(result.columns) == set(result.column_names)
    n = len(result)
    assert all(len(c) == n for c in result.columns.values())
    assert result.summary["scenario"] == "paper000-test3"


def test_columns_are_numpy_arrays_owned_by_the_native_vectors(result):
    t = result.columns["t_s"]
    assert t.dtype == np.float64 and t.flags["C_CONTIGUOUS"]
    assert not t.flags["OWNDATA"]  # numpy views the Rust Vec<f64> it was handed (no copy)


def test_to_pandas_and_polars_equal_the_columns_bit_for_bit(result):
    df = result.to_pandas()
    assert list(df.columns) == result.column_names
    pl = result.to_polars()
    assert pl.columns == result.column_names
    for n in result.column_names:
        a = result.columns[n]
        assert np.array_equal(df[n].to_numpy().view(np.uint64), a.view(np.uint64))
        assert np.array_equal(pl[n].to_numpy().view(np.uint64), a.view(np.uint64))


def test_missing_dataframe_libraries_raise_a_clear_import_error(result, monkeypatch):
    import sys

    for name, method in (("pandas", result.to_pandas), ("polars", result.to_polars)):
        monkeypatch.setitem(sys.modules, name, None)  # as if not installed
        with pytest.raises(ImportError, match=f"pip install {name}"):
            method()


def test_output_every_and_progress():
    sc = acs.Scenario.load(TEST3)
    seen = []
    r10 = acs.run(sc, output_every=10, progress=lambda done, total: seen.append((done, total)))
    # The CLI's step count ("4000 steps over 40 s"), reached once at the end (issue 38).
    assert seen and seen[-1][0] == seen[-1][1] == sc.steps == r10.summary["steps"]
    assert all(a[0] < b[0] for a, b in zip(seen, seen[1:]))
    r1 = acs.run(sc, output_every=1)
    every10 = r1.columns["t_s"][::10]
    if sc.steps % 10:
        every10 = np.append(every10, r1.columns["t_s"][-1])  # the last step is always recorded
    assert np.array_equal(r10.columns["t_s"], every10)
    assert r10.summary == {**r10.summary, "final_error_deg": r1.summary["final_error_deg"]}
    with pytest.raises(acs.ScenarioError, match="output_every"):
        acs.run(sc, output_every=0)
    acs.run(sc, progress=True)  # tqdm.auto when installed


def test_a_failed_run_is_returned_with_ok_false_and_a_warning(monkeypatch):
    """The Python layer's contract for a run that ends with run_status != "ok". Scenario
    validation refuses every input that would make a shipped model diverge, and a failing
    flight computer needs a corrupted link (sim-host/tests/honest_results.rs), so the
    native run's summary is altered here the way such a run reports it; that the native
    summary equals the CLI's is checked for every scenario in test_cli_equivalence.py."""
    native = acs._core.run

    def diverging(*args):
        summary, names, columns = native(*args)
        summary.update(run_status="diverged", failure={"Diverged": {"t_s": 1.5, "quantity": "body rate"}})
        return summary, names, columns

    monkeypatch.setattr(acs._core, "run", diverging)
    with pytest.warns(acs.RunStatusWarning, match="diverged"):
        r = acs.run(acs.Scenario.load(TEST3))
    assert not r.ok and r.status == "diverged"
    with pytest.raises(acs.RunFailed, match="body rate") as e:
        r.raise_for_status()
    assert e.value.result is r and isinstance(e.value, acs.AcsError)


def test_bad_arguments_raise_acs_errors():
    sc = acs.Scenario.load(TEST3)
    with pytest.raises(acs.ScenarioTypeError, match="acs.Scenario"):
        acs.run(str(TEST3))
    for bad in (True, -1, 0, 1.5, "10", 2**32):
        with pytest.raises(acs.ScenarioError, match="output_every"):
            acs.run(sc, output_every=bad)
    with pytest.raises(acs.RunError, match="link"):
        acs.run(sc, link=5)


def test_bad_links_raise_run_error():
    sc = acs.Scenario.load(TEST3)
    with pytest.raises(acs.RunError, match="unknown link"):
        acs.run(sc, link="pigeon")
    with pytest.raises(acs.RunError):
        acs.run(sc, link="tcp:127.0.0.1:1")  # nobody listens


def long_scenario():
    sc = acs.Scenario.load(TEST3)
    sc["duration_s"] = 1e6  # ~1e8 steps: far longer than the test waits
    return sc


def test_ctrl_c_stops_a_run():
    sc = long_scenario()
    threading.Timer(0.3, _thread.interrupt_main).start()
    t0 = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        acs.run(sc)
    assert time.monotonic() - t0 < 10


def test_an_exception_in_the_progress_callback_stops_the_run():
    def boom(done, total):
        raise RuntimeError("stop here")

    with pytest.raises(RuntimeError, match="stop here"):
        acs.run(long_scenario(), progress=boom)


def test_the_interpreter_lock_is_released_while_a_run_flies():
    sc = acs.Scenario.load(REPO / "scenarios/paper001/wheel-slew.toml")
    ticks = []
    done = threading.Event()

    def fly():
        acs.run(sc)
        done.set()

    th = threading.Thread(target=fly)
    th.start()
    while not done.is_set():
        ticks.append(time.monotonic())
        time.sleep(0.001)
    th.join()
    assert len(ticks) > 20  # the main thread kept running Python code meanwhile


def test_a_scenario_changed_while_it_flies_from_another_thread():
    """Issue 37: setting a key while acs.run flies the scenario raised a bare
    RuntimeError("Already borrowed"). The run flies a copy taken when it starts: the key
    is set at once, and the run's summary is that of the unchanged scenario (compared with
    a run of a copy; the changed scenario flies differently, so the check can fail)."""
    sc = acs.Scenario.load(TEST3)
    sc["duration_s"] = 400.0
    unchanged = acs.run(sc.copy()).summary
    flying, result = threading.Event(), {}
    changed_while_flying = []

    def progress(done, total):
        flying.set()
        time.sleep(0.002)  # keep the run going while the main thread changes the scenario

    th = threading.Thread(target=lambda: result.setdefault("r", acs.run(sc, progress=progress)))
    th.start()
    assert flying.wait(60)
    sc["controller.wn_rad_s"] = 2.0
    sc.update({"controller.zeta": 0.5, "initial.euler_deg[2]": 10.0})
    changed_while_flying.append(th.is_alive())
    assert sc["controller.wn_rad_s"] == 2.0 and sc["controller.zeta"] == 0.5
    th.join()
    assert changed_while_flying == [True]
    from conftest import without_wall_clock

    assert without_wall_clock(result["r"].summary) == without_wall_clock(unchanged)
    assert acs.run(sc).summary["final_error_deg"] != unchanged["final_error_deg"]


def test_margins_of_an_unstable_loop_fail_the_run_as_on_the_command_line():
    """Issue 37 finding 3 in Python: the unstable fixture (gains x 10, 0.2 s wheel-torque
    delay; closed-form phase margin -15.4 deg) with `[margins]` returns a failed run
    (`margins_failed`, the figures beside `stable` false), not an ok one."""
    import warnings

    text = (REPO / "tests/scenarios/margins/rigid-pd.toml").read_text()
    for old, new in [
        ("k_diag_nm = [5.0, 6.0, 7.5]", "k_diag_nm = [50.0, 60.0, 75.0]"),
        ("d_diag_nms = [7.0, 8.4, 10.5]", "d_diag_nms = [70.0, 84.0, 105.0]"),
        ("torque_limit_nm = [50.0, 50.0, 50.0]", "torque_limit_nm = [500.0, 500.0, 500.0]"),
        ("inertia_kgm2 = 0.01", "inertia_kgm2 = 0.01\ntorque_delay_s = 0.2"),
    ]:
        assert old in text, old
        text = text.replace(old, new)
    sc = acs.Scenario.from_toml(text + "\n[margins]\n")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", acs.RunStatusWarning)
        r = acs.run(sc)
    assert r.status == "margins_failed" and not r.ok, r.summary["failure"]
    m = r.summary["margins"]
    assert m["status"] == "unstable" and m["stable"] is False, m
    assert m["phase_margin_deg"] < 0.0, m
