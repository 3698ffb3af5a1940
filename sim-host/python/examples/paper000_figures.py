"""Paper 000 from Python: the attitude figure of test 1 (Euler angles against their target
and the attitude error, CMG pyramid, quaternion feedback) and the histogram of the
settling time of the dispersed test-3 campaign.

    python sim-host/python/examples/paper000_figures.py [OUT_DIR] [--runs N]

writes OUT_DIR/paper000-test1-attitude.png and OUT_DIR/paper000-test3-settle-histogram.png
(OUT_DIR defaults to out/python-example). Needs matplotlib, which the package's analysis
extra installs: pip install "./sim-host/python[analysis]". Kept runnable by
tests/test_example.py.
"""

import argparse
import json
from pathlib import Path

try:
    import matplotlib
except ImportError:  # the README's plain install has no plotting library
    raise SystemExit(
        "this example draws with matplotlib: pip install './sim-host/python[analysis]' (the package's analysis extra)"
    ) from None

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
    limit = next(r for r in merged["requirements"] if r["key"] == "settle_time_s")
    fig, ax = plt.subplots(figsize=(7, 4.2), layout="constrained")
    ax.hist(settle, bins=30, label=f"{len(settle)} of {merged['runs']} runs settled")
    ax.axvline(limit["value"], color="C3", linestyle="--", label=f"requirement: {limit['name']}")
    ax.set_xlim(0, limit["value"] * 1.1)
    ax.set_xlabel("settling time [s]")
    ax.set_ylabel("runs")
    ax.legend(loc="center right", bbox_to_anchor=(0.92, 0.62))  # between the runs and the limit
    verdict = "passed" if merged["passed"] else "not passed (report.md says why)"
    ax.set_title(f"{merged['campaign']}\ncampaign {verdict}", fontsize=10)
    path = out / "paper000-test3-settle-histogram.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("out", nargs="?", default=str(REPO / "out/python-example"))
    p.add_argument("--runs", type=int, default=300)  # 299 clean runs show 99 % at 95 % confidence
    a = p.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    for f in (attitude_figure(out), campaign_histogram(out, a.runs)):
        print("wrote", f)


if __name__ == "__main__":
    main()
