#!/usr/bin/env bash
# Counts the JSON parses on a job's path through the service (issue 46): every DOM parse of nlohmann-json goes
# through one of its `parser<...>::sax_parse_internal` instantiations, so a uprobe on each counts them all in
# the server process, whoever calls them: from POST /jobs of a tiny inline scene until the worker has stored
# its run, listed by the first function of ours on each parse's stack; then jobs naming a stored scene.
#
#   scripts/count_json_parses.sh [BUILD]      # as root, with perf and sqlite3; BUILD defaults to build
set -euo pipefail
BUILD=${1:-build}
BIN=$(realpath "$BUILD/runout")
WORK=$(mktemp -d)
PORT=18097
SERVER=""
trap 'kill $SERVER 2>/dev/null || true; perf probe -q -d "probe_runout:*" 2>/dev/null || true; rm -rf "$WORK"' EXIT

perf probe -q -d 'probe_runout:*' 2>/dev/null || true
k=0
for addr in $(nm "$BIN" | awk '$3 ~ /detail6parser.*sax_parse_internal/ {print $1}'); do  # by address: perf
  perf probe -q -x "$BIN" -a "json_parse_$k=0x$addr" && k=$((k + 1))                      # misses long names
done
[ "$k" -gt 0 ] || { echo "no nlohmann parser symbol in $BIN" >&2; exit 1; }

"$BIN" serve --port $PORT --db "$WORK/r.db" --workers 1 --shipped-studies off --scene-dir "$WORK" \
  >"$WORK/serve.log" 2>&1 &
SERVER=$!
for _ in $(seq 50); do curl -sf "localhost:$PORT/api/v1/health" >/dev/null && break; sleep 0.1; done

# The tiny scene of bench/service_bench.cpp: a job of well under a second.
cat >"$WORK/job.json" <<'EOF'
{"scene": {"name": "parse-count", "dimensions": 2, "dp": 0.02, "duration": 0.05,
  "materials": [{"name": "water", "rheology": "newtonian", "density": 1000, "viscosity": 0.001}],
  "fluid": [{"material": "water", "min": [0, 0], "max": [0.2, 0.2]}],
  "boundaries": [{"type": "tank", "min": [0, 0], "max": [0.4, 0.3]}]}}
EOF

# Every parse while "$@" runs, by the first function of ours that asked for it.
count() {
  perf record -q -e 'probe_runout:*' --call-graph dwarf,32768 -p $SERVER -o "$WORK/p.data" 2>/dev/null &
  local rec=$!
  sleep 0.5
  "$@"
  sleep 0.5
  kill -INT $rec
  wait $rec || true
  perf script -i "$WORK/p.data" 2>/dev/null |
    awk '/^runout / {want = 1; next} want && /runout::/ && !/nlohmann/ {sub(/^[ \t]*[0-9a-f]+ /, ""); sub(/\+0x.*/, ""); print; want = 0}' |
    sort | uniq -c | sort -rn
}

submit_and_wait() {
  local id
  id=$(curl -sf -X POST -H 'Content-Type: application/json' --data @"$WORK/job.json" \
    "localhost:$PORT/api/v1/jobs" | sed -n 's/.*"id":\([0-9]*\).*/\1/p')
  # Wait on the store, not on GET /jobs/ID (which parses the stored scene to answer it).
  for _ in $(seq 600); do
    [ "$(sqlite3 "$WORK/r.db" "SELECT status FROM jobs WHERE id = $id" 2>/dev/null)" = done ] && return 0
    sleep 0.1
  done
  echo "job $id did not finish" >&2
  return 1
}

echo "JSON parses from POST /jobs of an inline scene until the job is done, by caller:"
count submit_and_wait

# A job naming a stored scene: the scene stored first (POST /scenes, not counted), then two jobs on it. The
# first job of a process parses the stored scene once (JobQueue::scene_document keeps it); the next do not.
python3 -c 'import json,sys; print(json.dumps(json.load(open(sys.argv[1]))["scene"]))' "$WORK/job.json" >"$WORK/scene.json"
scene_id=$(curl -sf -X POST -H 'Content-Type: application/json' --data @"$WORK/scene.json" \
  "localhost:$PORT/api/v1/scenes" | sed -n 's/.*"id":\([0-9]*\).*/\1/p')
echo "{\"scene_id\": $scene_id}" >"$WORK/job.json"
echo "JSON parses from POST /jobs naming stored scene $scene_id until the job is done, the process's first such job:"
count submit_and_wait
echo "and the next:"
count submit_and_wait
