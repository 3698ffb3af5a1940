"""The worked example stays runnable: it writes both figures (Agg backend, temp dir)."""

import subprocess
import sys
from pathlib import Path

EXAMPLE = Path(__file__).resolve().parents[1] / "examples/paper000_figures.py"


def test_the_paper000_example_writes_its_figures(tmp_path):
    r = subprocess.run([sys.executable, str(EXAMPLE), str(tmp_path), "--runs", "40"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    for name in ("paper000-test1-attitude.png", "paper000-test3-settle-histogram.png"):
        png = tmp_path / name
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000, name
