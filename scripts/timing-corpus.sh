#!/usr/bin/env bash
# Remakes the worst-case timing corpus (timing/corpus/*.json, docs/timing.md): one
# seeded search of $EVALUATIONS (default 1500) evaluations per shipped closed-loop
# scenario on the QEMU firmware, or only for the scenarios given as arguments
# (e.g. paper004/dp-nominal; a path ending in .toml is taken as is, e.g. the issue 42
# base campaigns/base-3u-every-monitor.toml, a scenario). About 90 s per scenario at 1500 (the emulated UART bounds
# the evaluation rate).
#   scripts/timing-corpus.sh [paper000/test3 ...]
set -euo pipefail
EVALUATIONS="${EVALUATIONS:-1500}"
cd "$(dirname "$0")/.."
scripts/firmware.sh build
cargo build --release -p sim-host
bin=target/release/sim-host
ALL="modes/cubesat-mission paper000/test1 paper000/test2 paper000/test3 paper000/test4 \
    paper001/wheel-slew paper001/dmcs-m1 paper001/dmcs-m2 paper002/lqr paper002/lqg \
    paper002/gsr-manoeuvre paper002/lqr-gimbal-rates paper003/rig-lqr paper003/rig-pd \
    paper003/orbit-lqr paper003/orbit-mtq-hold paper003/bdot paper004/dp-nominal \
    paper004/bodson-nominal paper004/dp-fail-1-4 paper004/dp-fail-1-3-7 paper004/bodson-fail-1-4 \
    estimation/mekf-hold estimation/tracker-outage-eclipse estimation/sun-safe-from-tumble \
    guidance/eo-cubesat fdir/wheel-seized-6u fdir/gyro-stuck-in-slew-3u fdir/tracker-flip-3u \
    fdir/gyro-bias-step-3u campaigns/base-3u-every-monitor.toml"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for f in ${@:-$ALL}; do
    path="scenarios/$f.toml"
    [[ $f == *.toml ]] && path=$f
    name=$("$bin" check "$path" | head -1 | cut -d: -f1)
    # A regression corpus only grows in cost: the previous entries seed the new search.
    seed=()
    if [ -f "timing/corpus/$name.json" ]; then
        cp "timing/corpus/$name.json" "$tmp/$name.json"
        seed=(--seed-corpus "$tmp/$name.json")
    fi
    # The search exits 1 when its worst is over budget, after writing the corpus.
    "$bin" timing search "$path" --seed 1 --evaluations "$EVALUATIONS" --budget-seconds 240 \
        "${seed[@]}" --out "timing/corpus/$name.json" | grep -v "worst input" || true
done
