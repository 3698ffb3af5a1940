#!/usr/bin/env bash
# Record or check the fingerprint of every shipped scenario run in-process: summary.json
# without its wall-clock fields, and the SHA-256 of timeseries.csv. A refactor that must
# not change any result is checked with `scripts/golden.sh check FILE`. Each scenario is
# also run with the default `--format parquet` and its columns compared bit for bit with
# the CSV (`sim-host compare-series`); a difference fails both modes.
#   scripts/golden.sh record FILE   write the fingerprints of this tree's build to FILE
#   scripts/golden.sh check FILE    compare this tree's build with FILE (exit 1 on a difference)
# scripts/golden-fingerprints.tsv holds the fingerprints of the committed tree on the project machine.
set -euo pipefail
cd "$(dirname "$0")/.."
mode=${1:?record|check}; file=${2:?fingerprint file}
cargo build --release -q -p sim-host
bin=${CARGO_TARGET_DIR:-target}/release/sim-host
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
out="$tmp/fingerprints"
# Fields that depend on the host's clock, not on the simulation.

run_one() {
  local sc=$1 name dir
  name=$(echo "$sc" | tr '/' '_')
  dir="$tmp/$name"
  "$bin" run "$sc" --out "$dir" --no-plots --quiet --link in-process --format csv >/dev/null
  "$bin" run "$sc" --out "$dir.pq" --no-plots --quiet --link in-process --format parquet >/dev/null
  if ! "$bin" compare-series "$dir/timeseries.csv" "$dir.pq/timeseries.parquet" >/dev/null 2>"$dir.cmp"; then
    echo "golden: $sc: timeseries.parquet differs from timeseries.csv: $(cat "$dir.cmp")" >&2
    touch "$tmp/parquet-differs"
  fi
  printf '%s\t%s\t%s\n' "$sc" "$(sha256sum "$dir/timeseries.csv" | cut -c1-64)" \
    "$(python3 -c "import json,sys; d=json.load(open(sys.argv[1])); [d.pop(k,None) for k in ('wall_time_s','real_time_factor','mean_step_us','max_step_us','allocation_us_per_call','max_step_ticks')]; print(json.dumps(d,sort_keys=True))" "$dir/summary.json")"
  rm -rf "$dir" "$dir.pq" "$dir.cmp"
}
export -f run_one; export bin tmp
ls scenarios/*/*.toml | sort | xargs -P 2 -I{} bash -c 'run_one {}' > "$out.unsorted"
sort "$out.unsorted" > "$out"
if [ -e "$tmp/parquet-differs" ]; then echo "golden: Parquet and CSV columns differ (above)"; exit 1; fi
case $mode in
  record) cp "$out" "$file"; echo "recorded $(wc -l < "$file") scenarios in $file" ;;
  check)
    if diff <(cut -f1,2 "$file") <(cut -f1,2 "$out") >/dev/null && diff "$file" "$out" >/dev/null; then
      echo "golden: all $(wc -l < "$file") scenarios identical"
    else
      echo "golden: differences (< recorded, > now):"; diff "$file" "$out" | cut -c1-400; exit 1
    fi ;;
  *) echo "unknown mode $mode" >&2; exit 2 ;;
esac
