#!/usr/bin/env bash
# Equal-time caustics benchmark, one command (from anywhere):
#
#   bench/caustics/run.sh [driver flags]      e.g. --budget 60 --ref-budget 1800
#   bench/caustics/run.sh --budget 10 --ref-budget 60 --caustics-integrator path --ref-integrator path
#
# Installs what the peers need when missing (apt libllvm19 for Mitsuba's LLVM variants; a peer
# venv with mitsuba, pillow, numpy, usd-core), copies the shared bench folder to a temp dir,
# writes the scenes with its scenes.py and runs driver.py there; Tide renders through the
# repository's ./tide (build it first: bash scripts/setup.sh). Results go to OUT (default
# bench/caustics/out/run-<date>): results.md (the table), results.json, and every render as .npy.
# Environment: TIDE_BENCH_OUT (output dir), TIDE_BENCH_VENV (peer venv, default
# bench/caustics/out/venv, reused between runs), SHARED_BENCH (peer folder), TIDE_BENCH_KEEP=1
# keeps the temp copy.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
repo=$(cd "$here/../.." && pwd)
shared=${SHARED_BENCH:-$repo/../shared/bench}
[ -d "$shared" ] || shared=/work/shared/bench
out=${TIDE_BENCH_OUT:-$here/out/run-$(date +%Y%m%d-%H%M%S)}
venv=${TIDE_BENCH_VENV:-$here/out/venv}
llvm=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1

[ -x "$repo/tide" ] && [ -f "$repo/cpp-bridge/python/tide/_tide.so" ] ||
    { echo "run.sh: Tide is not built; run: bash scripts/setup.sh" >&2; exit 1; }
if ! [ -f "$llvm" ]; then
    if [ "$(id -u)" = 0 ]; then apt-get install -y libllvm19 >&2; else sudo apt-get install -y libllvm19 >&2; fi
fi
export DRJIT_LIBLLVM_PATH=$llvm      # Debian's LLVM 14/15 abort inside Mitsuba's JIT
if ! [ -x "$venv/bin/python" ] || ! "$venv/bin/python" -c 'import mitsuba, PIL, numpy, pxr' 2>/dev/null; then
    python3 -m venv "$venv" >&2
    "$venv/bin/pip" install -q mitsuba pillow numpy usd-core >&2
fi

tmp=$(mktemp -d)
if [ -z "${TIDE_BENCH_KEEP:-}" ]; then trap 'rm -rf "$tmp"' EXIT; else echo "keeping $tmp" >&2; fi
cp -r "$shared" "$tmp/bench" && chmod -R u+w "$tmp/bench"
(cd "$tmp/bench" && "$venv/bin/python" scenes.py >&2)
mkdir -p "$out"
"$venv/bin/python" "$here/driver.py" --bench "$tmp/bench" --repo "$repo" --out "$out" "$@"
echo "results: $out/results.md" >&2
