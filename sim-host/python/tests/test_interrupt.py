"""Ctrl-C in every phase of a run (issue 37): a child interpreter starts a long run, the
test sends it SIGINT, and the child must raise KeyboardInterrupt (not acs.InternalError,
no Rust panic on stderr) within a second of the signal — in the run itself, in the
`[margins]` measurement after it (experiments on worker threads), and in a campaign
(runs and their margins on worker threads; interrupted runs leave no result, so the
shard resumes with them). Latency: the child's time.monotonic() when it caught the
exception minus the parent's when it sent the signal (CLOCK_MONOTONIC: one clock for
both processes on Linux)."""

import signal
import subprocess
import sys
import textwrap
import time

import pytest

import acs
from conftest import REPO

LATENCY_S = 1.0

CHILD = textwrap.dedent(
    """
    import sys, time
    import acs

    phase, arg = sys.argv[1], sys.argv[2]
    said = []

    def ready(*_):
        if not said:
            said.append(1)
            print("READY", flush=True)

    try:
        if phase == "run":
            sc = acs.Scenario.load(arg)
            sc["duration_s"] = 1e6  # ~1e8 steps: hours
            acs.run(sc, progress=ready)
        elif phase == "margins":
            # test3's 40 s run, then margins at t = 30 s on the finest grid (about 40 s);
            # ready once the run has flown its last step.
            sc = acs.Scenario.from_toml(open(arg).read() + "\\n[margins]\\nat_s = 30.0\\ngrid_points = 400\\n")
            acs.run(sc, progress=lambda done, total: done >= total and ready())
        elif phase == "campaign":
            ready()
            acs.campaign.run(arg, jobs=2)
        print("FINISHED", flush=True)
    except BaseException as e:
        print("CAUGHT", f"{type(e).__module__}.{type(e).__name__}", repr(time.monotonic()), flush=True)
    """
)


def interrupt(phase, arg, after_s):
    """Starts the child, sends SIGINT `after_s` after it said READY; returns (what it
    caught, latency s, stderr)."""
    p = subprocess.Popen(
        [sys.executable, "-c", CHILD, phase, str(arg)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        assert p.stdout.readline().strip() == "READY", p.stderr.read()
        time.sleep(after_s)
        sent = time.monotonic()
        p.send_signal(signal.SIGINT)
        out, err = p.communicate(timeout=120)
    finally:
        p.kill()
    words = out.split()
    assert words[:1] == ["CAUGHT"], (out, err)
    latency = float(words[2]) - sent
    print(f"{phase}: {words[1]} {latency * 1000:.0f} ms after SIGINT")
    return words[1], latency, err


def check(caught, latency, err):
    assert caught == "builtins.KeyboardInterrupt", err
    assert "panicked" not in err and "Traceback" not in err, err
    assert 0.0 <= latency < LATENCY_S


def test_ctrl_c_in_the_run_phase():
    check(*interrupt("run", REPO / "scenarios/paper000/test3.toml", 0.5))


def test_ctrl_c_in_the_margins_phase():
    check(*interrupt("margins", REPO / "scenarios/paper000/test3.toml", 1.0))


LONG_FLIGHTS = """
name = "test3-long"
base = "{base}"
runs = 4
seed = 1

[[dispersion]]
key = "duration_s"
dist = {{ type = "choice", values = [100000.0] }}
"""


@pytest.mark.parametrize("phase", ["flights", "margins"])
def test_ctrl_c_in_a_campaign(tmp_path, phase):
    """`flights`: four runs of 1e5 s (minutes each); `margins`: the shipped margins
    campaign, whose runs spend seconds in their `[margins]` measurement."""
    if phase == "flights":
        spec = tmp_path / "long.toml"
        spec.write_text(LONG_FLIGHTS.format(base=REPO / "scenarios/paper000/test3.toml"))
    else:
        spec = REPO / "campaigns/paper000-test3-margins.toml"
    out = tmp_path / "c"
    acs.campaign.plan(spec, out, runs=4)
    caught, latency, err = interrupt("campaign", out, 1.5)
    check(caught, latency, err)
    # The runs in flight were cut short: none wrote a result, so a resume flies them.
    assert not list(out.glob("runs/*/result.json"))


def interrupt_main_after(delay_s, call):
    """`call()` in this process, Ctrl-C (`_thread.interrupt_main`) after `delay_s`;
    returns the seconds from the interrupt to the KeyboardInterrupt."""
    import _thread
    import threading

    sent = []
    timer = threading.Timer(delay_s, lambda: (sent.append(time.monotonic()), _thread.interrupt_main()))
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            call()
        return time.monotonic() - sent[0]
    finally:
        timer.cancel()


def test_an_interrupted_run_or_campaign_leaves_the_process_usable(tmp_path):
    """After an interrupt the next call in the same process works: a run gives the same
    summary as before the interrupted one (no worker left running), and a campaign shard
    can be run again (its lock was released: otherwise `acs.CampaignError`)."""
    from conftest import without_wall_clock

    sc = acs.Scenario.load(REPO / "scenarios/paper000/test3.toml")
    first = without_wall_clock(acs.run(sc).summary)
    long = acs.Scenario.from_toml(sc.to_toml() + "\n[margins]\nat_s = 30.0\ngrid_points = 400\n")
    assert interrupt_main_after(1.5, lambda: acs.run(long)) < LATENCY_S
    assert without_wall_clock(acs.run(sc).summary) == first
    spec = tmp_path / "long.toml"
    spec.write_text(LONG_FLIGHTS.format(base=REPO / "scenarios/paper000/test3.toml"))
    acs.campaign.plan(spec, tmp_path / "c", runs=2)
    for _ in range(2):
        assert interrupt_main_after(1.0, lambda: acs.campaign.run(tmp_path / "c", jobs=2)) < LATENCY_S
    assert not list((tmp_path / "c").glob("runs/*/result.json"))
