#!/usr/bin/env bash
# Tide's BVH against Embree on the same ocean mesh and rays, in one run, on the same thread counts.
#
#   bench/run_rays.sh [ROUNDS]        (from anywhere; ROUNDS alternations of the two peers, default 3)
#
# Copies ../shared/bench to a temp dir, installs what it needs (apt libembree-dev, a venv with
# numpy), generates the data, builds embree_rays and Tide's rays bench, then runs Embree and Tide
# alternately ROUNDS times at 1 and 2 threads and prints the best figure of each and their ratios.
# TIDE_BENCH_KEEP=1 keeps the temp dir; SHARED_BENCH overrides the peer folder.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
repo=$(dirname "$here")
shared=${SHARED_BENCH:-$repo/../shared/bench}
[ -d "$shared" ] || shared=/work/shared/bench
rounds=${1:-3}

tmp=$(mktemp -d)
if [ -z "${TIDE_BENCH_KEEP:-}" ]; then trap 'rm -rf "$tmp"' EXIT; else echo "keeping $tmp" >&2; fi
cp -r "$shared" "$tmp/bench" && chmod -R u+w "$tmp/bench"
cd "$tmp/bench"

if ! [ -f /usr/include/embree3/rtcore.h ]; then
    if [ "$(id -u)" = 0 ]; then apt-get install -y libembree-dev >&2; else sudo apt-get install -y libembree-dev >&2; fi
fi
python3 -m venv venv >&2 && venv/bin/pip install -q numpy >&2
venv/bin/python embree_bench.py gen >&2
g++ -O3 -march=native -std=c++17 embree_cpp/embree_rays.cpp -lembree3 -lpthread -o embree_rays

(cd "$repo" && cargo bench -p tide-core --bench rays --no-run >&2)
tide=$(cd "$repo" && cargo bench -p tide-core --bench rays --no-run --message-format=json 2>/dev/null |
    python3 -c 'import json,sys
for l in sys.stdin:
    m = json.loads(l)
    if m.get("reason") == "compiler-artifact" and m["target"]["name"] == "rays" and m.get("executable"): print(m["executable"])')

: > embree.jsonl; : > tide.jsonl
for r in $(seq "$rounds"); do
    for t in 1 2; do
        ./embree_rays data "$t" | tee -a embree.jsonl >&2
    done
    # the brute-force check runs once; later rounds only time
    checks=64; [ "$r" = 1 ] || checks=0
    TIDE_BENCH_CHECKS=$checks "$tide" data 1,2 | tee -a tide.jsonl >&2
done

python3 - "$rounds" <<'PY'
import json, sys
E = [json.loads(l) for l in open("embree.jsonl")]
T = [json.loads(l) for l in open("tide.jsonl")]
best = lambda xs: max(xs) if xs else float("nan")
print(f"Tide / Embree {E[0]['embree']}, {E[0]['triangles']} triangles, best of {sys.argv[1]} alternating rounds")
print(f"| measure | threads | Embree | Tide | Tide/Embree |")
print(f"|---|---|---|---|---|")
for kind in ["incoherent", "coherent"]:
    for t in [1, 2]:
        e = best([x[f"{kind}_mrays_s"] for x in E if x["threads"] == t])
        m = best([x[f"{kind}_t{t}_mrays_s"] for x in T])
        print(f"| {kind} closest hit, Mrays/s | {t} | {e:.3f} | {m:.3f} | {m / e:.2f} |")
    eh, th = E[0][f"{kind}_hit_fraction"], T[0][f"{kind}_t1_hit_fraction"]
    print(f"| {kind} hit fraction | | {eh:.6f} | {th:.6f} | |")
eb = min(x["build_s"] for x in E)
tb = min(x["build_s"] for x in T)
print(f"| build s, best of all runs (both may use both cores) | | {eb:.3f} | {tb:.3f} | {tb / eb:.2f} |")
print(f"| bytes per triangle | | ~77 (README) | {T[0]['bytes_per_triangle']:.1f} | |")
bad = sum(x.get(f"{k}_brute_force_mismatches", 0) for x in T for k in ["incoherent", "coherent"])
print(f"brute-force mismatches: {bad}")
PY
