#!/usr/bin/env bash
# Builds the QEMU cycle-estimation plugin (GPL-2.0-or-later, see LICENSE-NOTE.md) into
# target/qemu-cycles/libcycles.so (or $1) and prints its path. Needs only a C compiler:
# the plugin ABI subset it uses is declared in plugin-api.h.
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
ROOT="$(cd "$HERE/../.." && pwd)"
OUT="${1:-$ROOT/target/qemu-cycles/libcycles.so}"
CC="${CC:-cc}"
mkdir -p "$(dirname "$OUT")"
if [[ ! -f "$OUT" || "$HERE/cycles.c" -nt "$OUT" || "$HERE/plugin-api.h" -nt "$OUT" ]]; then
    "$CC" -std=gnu11 -O2 -Wall -Wextra -fPIC -shared -fvisibility=hidden \
        -o "$OUT.tmp.$$" "$HERE/cycles.c"
    mv -f "$OUT.tmp.$$" "$OUT"  # atomic: concurrent builds (parallel tests) never see a partial file
fi
echo "$OUT"
