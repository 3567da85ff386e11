#!/usr/bin/env bash
# Sync cost at the Rust level (delegate + core build, no USD, no Python): runs each case of
# delegate/benches/front_door_sync.rs in REPEATS fresh processes (peak RSS is per process)
# and prints every run, then the median of each figure.
#   bash bench/front_door_rust.sh [REPEATS] [CASE...]     (defaults: 5, mesh2m points1m resync1000)
set -euo pipefail
cd "$(dirname "$0")/.."
repeats="${1:-5}"
shift || true
cases=("$@")
((${#cases[@]})) || cases=(mesh2m points1m resync1000)
cargo bench -p tide-delegate --bench front_door_sync --no-run 2>/dev/null
bin=$(cargo bench -p tide-delegate --bench front_door_sync --no-run --message-format=json 2>/dev/null |
    python3 -c 'import json,sys
for l in sys.stdin:
    m = json.loads(l)
    if m.get("reason") == "compiler-artifact" and m["target"]["name"] == "front_door_sync" and m.get("executable"):
        print(m["executable"])')
for c in "${cases[@]}"; do
    runs=$(for _ in $(seq "$repeats"); do "$bin" "$c"; done)
    echo "$runs"
    echo "$runs" | python3 -c 'import json,statistics,sys
runs = [json.loads(l) for l in sys.stdin if l.strip()]
med = {"case": runs[0]["case"], "repeats": len(runs), "median": True}
for k, v in runs[0].items():
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        med[k] = round(statistics.median(r[k] for r in runs), 4)
print(json.dumps(med))'
done
