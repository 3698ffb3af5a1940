#!/usr/bin/env bash
# The Python package's tests (sim-host/python/tests, pytest): creates the virtual
# environment target/py-venv, installs the package from the tree (`pip install
# ./sim-host/python`: maturin builds the native module into target/, warm after a cargo
# build) with what the tests need, then runs pytest. Extra arguments go to pytest
# (e.g. `-k fsw`, `-x`).
#
# A missing `python3` or `venv` module fails under CI (`CI` set) and otherwise skips
# loudly, with one line in target/skipped-tests.log (the rule of
# sim-host/tests/support/require_tool.rs); scripts/setup.sh installs them.
set -euo pipefail
cd "$(dirname "$0")/.."

VENV=${ACS_PY_VENV:-target/py-venv}
PY=${PYTHON:-python3}
TEST_DEPS=(pytest numpy pandas polars pyarrow hypothesis matplotlib tqdm control scipy astropy)

missing() {
  local why=$1
  if [ -n "${CI:-}" ] && [ "${CI}" != 0 ] && [ "${CI}" != false ]; then
    echo "python-tests: $why (CI: failing; scripts/setup.sh installs python3 and python3-venv)" >&2
    exit 1
  fi
  echo "SKIPPED (tool missing): [python3/venv] sim-host/python/tests: $why; scripts/setup.sh installs it" >&2
  mkdir -p target
  echo "[python3/venv] sim-host/python/tests (pytest): $why; scripts/setup.sh installs it" >>target/skipped-tests.log
  exit 0
}

command -v "$PY" >/dev/null 2>&1 || missing "no $PY"
if [ ! -x "$VENV/bin/python" ]; then
  "$PY" -m venv "$VENV" || { rm -rf "$VENV"; missing "$PY -m venv failed (Debian/Ubuntu: apt-get install python3-venv)"; }
fi
"$VENV/bin/python" -m pip install -q --upgrade pip
"$VENV/bin/python" -m pip install -q "${TEST_DEPS[@]}"
"$VENV/bin/python" -m pip install -q --force-reinstall --no-deps ./sim-host/python
cargo build --release -q -p sim-host   # the CLI the tests compare with
cd sim-host/python
exec "../../$VENV/bin/python" -m pytest -q "$@"
