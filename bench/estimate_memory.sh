#!/usr/bin/env bash
# Server CPU and peak memory of POST /estimate (docs/performance.md, "Estimates that count, and layers kept"):
# starts `runout serve --workers 0 --scene-dir scenarios`, posts the scene once, then N times, and prints the
# first request's CPU, the mean of the next N (/proc/PID/stat, user + system, a 10 ms clock) and the server's
# peak resident memory (VmHWM). The scene's file names are made relative to scenarios/ as the service wants.
#
#   bench/estimate_memory.sh BIN SCENE FIDELITY [N]
#   bench/estimate_memory.sh build/runout scenarios/catchment/alr.json standard 30
set -euo pipefail
BIN=$(realpath "$1"); SCENE=$(realpath "$2"); FIDELITY=$3; N=${4:-30}
ROOT=$(realpath "$(dirname "$0")/..")
WORK=$(mktemp -d); PORT=18093; PID=""
trap 'kill $PID 2>/dev/null || true; rm -rf "$WORK"' EXIT
/usr/bin/python3 - "$SCENE" "$ROOT/scenarios" "$FIDELITY" >"$WORK/body.json" <<'PY'
import json, os, sys
scene, root, fidelity = sys.argv[1:4]
s = json.load(open(scene))
def rebase(o):
    items = o.items() if isinstance(o, dict) else enumerate(o) if isinstance(o, list) else []
    for k, v in items:
        if k in ("dem", "layer") and isinstance(v, str):
            o[k] = os.path.relpath(os.path.normpath(os.path.join(os.path.dirname(scene), v)), root)
        else:
            rebase(v)
rebase(s)
print(json.dumps({"scene": s, "fidelity": fidelity}))
PY
"$BIN" serve --port $PORT --db "$WORK/r.db" --workers 0 --shipped-studies off --scene-dir "$ROOT/scenarios" \
  >"$WORK/serve.log" 2>&1 &
PID=$!
for _ in $(seq 100); do curl -sf localhost:$PORT/api/v1/health >/dev/null && break; sleep 0.1; done
cpu() { awk '{print $14 + $15}' /proc/$PID/stat; }
post() { curl -s -o "$WORK/out.json" -w "%{http_code}" -X POST -H 'Content-Type: application/json' \
  --data @"$WORK/body.json" localhost:$PORT/api/v1/estimate; }
TCK=$(getconf CLK_TCK)
c0=$(cpu); code=$(post); c1=$(cpu)
for _ in $(seq "$N"); do post >/dev/null; done
c2=$(cpu)
rss=$(awk '/VmHWM/ {printf "%.1f", $2 / 1024}' /proc/$PID/status)
echo "status $code; first $(( (c1 - c0) * 1000 / TCK )) ms; next $(echo "($c2 - $c1) * 1000 / $TCK / $N" | bc -l |
  xargs printf %.1f) ms each; peak RSS $rss MB; particles $(/usr/bin/python3 -c \
  "import json; print(json.load(open('$WORK/out.json')).get('particles', {}).get('total'))")"
