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


def test_without_matplotlib_the_example_names_the_install_command(tmp_path):
    # sys.modules[name] = None makes `import name` raise ImportError: the README's plain
    # install, which has no matplotlib (issue 38).
    code = (
        "import runpy, sys; sys.modules['matplotlib'] = None; "
        f"sys.argv = ['x', {str(tmp_path)!r}]; runpy.run_path({str(EXAMPLE)!r}, run_name='__main__')"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 1, (r.returncode, r.stderr)
    assert "./sim-host/python[analysis]" in r.stderr, r.stderr
    assert not list(tmp_path.iterdir())
