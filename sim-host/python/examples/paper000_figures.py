"""Paper 000 from Python: the attitude figure of test 1 (Euler angles against their target
and the attitude error, CMG pyramid, quaternion feedback) and the histogram of the
settling time of the dispersed test-3 campaign.

    python sim-host/python/examples/paper000_figures.py [OUT_DIR] [--runs N]

writes OUT_DIR/paper000-test1-attitude.png and OUT_DIR/paper000-test3-settle-histogram.png
(OUT_DIR defaults to out/python-example). Kept runnable by tests/test_example.py.
"""

import argparse
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only: also works without a display
import matplotlib.pyplot as plt  # noqa: E402

import acs  # noqa: E402

REPO = Path(__file__).resolve().parents[3]


def attitude_figure(out: Path) -> Path:
    """Paper 000, test 1: roll, pitch and yaw with the targets (dashed), and the error."""
    r = acs.run(acs.Scenario.load(REPO / "scenarios/paper000/test1.toml")).raise_for_status()
    c = r.columns
    fig, axes = plt.subplots(4, 1, figsize=(7, 9), sharex=True)
    for ax, axis in zip(axes, ["roll", "pitch", "yaw"]):
        ax.plot(c["t_s"], c[f"{axis}_deg"], label=axis)
        ax.plot(c["t_s"], c[f"{axis}_target_deg"], "--", label="target")
        ax.set_ylabel(f"{axis} [deg]")
        ax.legend(loc="right")
    axes[3].semilogy(c["t_s"], c["error_deg"])
    axes[3].set_ylabel("error [deg]")
    axes[3].set_xlabel("time [s]")
    fig.suptitle(f"{r.summary['scenario']}: final error {r.summary['final_error_deg']:.2e} deg")
    path = out / "paper000-test1-attitude.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def campaign_histogram(out: Path, runs: int) -> Path:
    """The dispersed test-3 campaign: planned, flown and merged from Python, then the
    settling time of every run that flew (from each run's result.json)."""
    d = out / "paper000-test3-campaign"
    acs.campaign.plan(REPO / "campaigns/paper000-test3-dispersed.toml", d, runs=runs)
    acs.campaign.run(d)
    merged = acs.campaign.merge(d, plots=False)
    settle = []
    for f in sorted((d / "runs").glob("*/result.json")):
        s = json.loads(f.read_text()).get("summary") or {}
        if s.get("settle_time_s") is not None:
            settle.append(s["settle_time_s"])
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.hist(settle, bins=30)
    ax.set_xlabel("settling time [s]")
    ax.set_ylabel("runs")
    verdict = "passed" if merged["passed"] else "not passed (too few runs or a requirement missed: report.md)"
    ax.set_title(f"{merged['campaign']}: {len(settle)} of {merged['runs']} runs settled; campaign {verdict}")
    path = out / "paper000-test3-settle-histogram.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("out", nargs="?", default=str(REPO / "out/python-example"))
    p.add_argument("--runs", type=int, default=200)
    a = p.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    for f in (attitude_figure(out), campaign_histogram(out, a.runs)):
        print("wrote", f)


if __name__ == "__main__":
    main()
