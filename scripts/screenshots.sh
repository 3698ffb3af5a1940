#!/usr/bin/env bash
# The 3D replay's screenshots in the docs, regenerated: the shipped mission
# (scenarios/modes/cubesat-mission.toml) in LVLH during its hold and in the orbit view, and
# paper000 test 1's CMG slew, each flown, written as a replay page (`sim-host run --view`)
# and shot in Debian's headless Chromium by tools/viewer/test/drive.mjs
# (docs/viewer.md). Needs scripts/setup.sh (node, chromium, the viewer bundle).
# Look at the PNGs before committing them.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -q -p sim-host
work=target/screenshots
mkdir -p "$work" docs/images
fly() { target/release/sim-host run "$1" --out "$work/$2" --no-plots --quiet --view; }
fly scenarios/modes/cubesat-mission.toml mission
fly scenarios/paper000/test1.toml cmg-slew
shoot() {
  local page=$1 ops=$2
  printf '{"page": "%s", "width": 1280, "height": 800, "ops": %s}\n' "$page" "$ops" >"$work/script.json"
  node tools/viewer/test/drive.mjs "$work/script.json" >"$work/drive.json"
  python3 -c 'import json,sys; d=json.load(open(sys.argv[1])); bad=d["consoleErrors"]+d["pageErrors"]+d["requests"]; sys.exit(f"page errors: {bad}" if bad else 0)' "$work/drive.json"
}
shoot "$work/mission/replay.html" '[
  {"op": "screenshot", "t": 5200, "camera": "lvlh", "path": "docs/images/replay-mission.png"},
  {"op": "screenshot", "t": 5200, "camera": "orbit", "path": "docs/images/replay-mission-orbit.png"}]'
shoot "$work/cmg-slew/replay.html" '[
  {"op": "screenshot", "t": 8, "camera": "inertial", "path": "docs/images/replay-cmg-slew.png"}]'
ls -l docs/images/replay-*.png
