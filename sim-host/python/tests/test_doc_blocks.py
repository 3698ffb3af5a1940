"""Every code block of README.md and docs/python.md runs as written, or says why not.

A fenced ```sh or ```python block runs unless the line before its fence is a marker
`<!-- not run: REASON -->` with a reason (a block that builds or installs for minutes,
needs QEMU, or is the suite itself). Blocks run the way a reader runs them from the
repository root, in a scratch directory that stands for it: `scenarios`, `campaigns`,
`sim-host`, `timing` and `docs` are links to the repository's, `.venv` is the virtual
environment running this test (scripts/python-tests.sh: the package and its `analysis`
extra), and `target/release` (the `sim-host` command the suite built) is on PATH as the
README's first block puts it there. So what the blocks write (`out/...`) stays out of the
working tree. Shell blocks run with `bash -euo pipefail`, one process per block; the
Python blocks of one document run in order in one namespace, as a reader types them into
one session. A block that fails (non-zero exit, an exception) fails the test, naming the
document and line.
"""

import os
import re
import subprocess
import sys
import traceback
from pathlib import Path

import pytest

from conftest import REPO, TARGET

DOCS = ["README.md", "docs/python.md"]
FENCE = re.compile(r"^```(\w*)\s*$")
MARKER = re.compile(r"^<!--\s*not run:\s*(.*?)\s*-->$")
LINKED = ["scenarios", "campaigns", "sim-host", "timing", "docs"]
# Each block within this, in seconds (the campaign block flies 1,000 runs: ~5 s on 2 cores).
TIMEOUT_S = 240


def blocks(doc):
    """(language, first line number, code, not-run reason or None) of each fenced block."""
    lines = (REPO / doc).read_text().splitlines()
    out, i = [], 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        start, lang = i, m.group(1)
        j = i + 1
        while j < len(lines) and not lines[j].startswith("```"):
            j += 1
        prev = lines[start - 1].strip() if start > 0 else ""
        marker = MARKER.match(prev)
        out.append((lang, start + 1, "\n".join(lines[start + 1 : j]) + "\n", marker.group(1) if marker else None))
        i = j + 1
    return out


ALL = [(doc, *b) for doc in DOCS for b in blocks(doc)]


def test_every_block_is_run_or_says_why_not():
    assert ALL, "no code blocks found"
    for doc, lang, line, code, reason in ALL:
        assert lang in ("sh", "python"), f"{doc}:{line}: block of language {lang!r} (sh or python)"
        assert reason is None or len(reason) > 10, f"{doc}:{line}: not-run marker without a reason"
    # The markers are next to blocks, not stray.
    for doc in DOCS:
        text = (REPO / doc).read_text().splitlines()
        for k, l in enumerate(text):
            if MARKER.match(l.strip()):
                assert k + 1 < len(text) and FENCE.match(text[k + 1]), f"{doc}:{k + 1}: marker not before a fence"


@pytest.fixture(scope="module")
def reader_root(tmp_path_factory, sim_host):
    """A scratch directory standing for the repository root (see the module docstring)."""
    root = tmp_path_factory.mktemp("reader")
    for name in LINKED:
        (root / name).symlink_to(REPO / name)
    (root / ".venv").symlink_to(Path(sys.prefix))
    env = dict(os.environ, PATH=f"{sim_host.parent}{os.pathsep}{os.environ['PATH']}", MPLBACKEND="Agg")
    return root, env


SH = [(doc, line, code) for doc, lang, line, code, reason in ALL if lang == "sh" and reason is None]


@pytest.mark.parametrize("doc,line,code", SH, ids=[f"{d}:{l}" for d, l, _ in SH])
def test_shell_block_runs(doc, line, code, reader_root):
    root, env = reader_root
    r = subprocess.run(
        ["bash", "-euo", "pipefail", "-c", code],
        cwd=root,
        env=env,
        capture_output=True,
        text=True,
        timeout=TIMEOUT_S,
    )
    assert r.returncode == 0, f"{doc}:{line} exited {r.returncode}:\n{code}\nstdout:\n{r.stdout[-3000:]}\nstderr:\n{r.stderr[-3000:]}"


@pytest.mark.parametrize("doc", DOCS)
def test_python_blocks_run(doc, reader_root, monkeypatch):
    root, env = reader_root
    monkeypatch.chdir(root)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    namespace = {"__name__": "__doc_blocks__"}
    ran = 0
    for d, lang, line, code, reason in ALL:
        if d != doc or lang != "python" or reason is not None:
            continue
        try:
            exec(compile(code, f"{doc}:{line}", "exec"), namespace)
        except Exception:
            pytest.fail(f"{doc}:{line} raised:\n{code}\n{traceback.format_exc()}")
        ran += 1
    assert ran > 0, f"{doc}: no Python block ran"
