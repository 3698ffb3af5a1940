#!/usr/bin/env bash
# Regenerate the reproduction report (every shipped scenario, the published outcomes beside
# ours, the experiments) into DIR (default out/report: report.md, index.html, figures/) and
# its committed copy docs/results.md. sim-host/tests/report.rs fails when the copy is stale.
#   scripts/report.sh [DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-out/report}
cargo run --release -q -p sim-host -- report --out "$out"
cp "$out/report.md" docs/results.md
echo "docs/results.md updated; open $out/index.html for the figures"
