#!/usr/bin/env bash
# Two builds side by side, alternating (docs/performance.md, "Runs repeat to the bit"): the 3D dam break's
# throughput at two threads and at one, and the flume's C0 at draft with two threads (wall time of the whole run).
# Run from the repository root on a quiet machine:
#   bench/two_builds.sh OLD_BUILD_DIR NEW_BUILD_DIR [OUT_DIR] [ROUNDS]
set -uo pipefail
OLD=$(realpath "$1"); NEW=$(realpath "$2")
OUT=${3:-/tmp/two-builds-bench}; ROUNDS=${4:-3}
mkdir -p "$OUT"; : > "$OUT/results.txt"
dam() { "$1/bench/bench_dam_break_3d" --dp 0.016 --steps 80 --warmup 10 --threads "$2" --only-throughput 2>&1 | tail -1; }
flume() {  # build tag: prints the run's wall time [s]
  local t0 t1
  t0=$(date +%s.%N)
  "$1/runout" run scenarios/flume/c0_c7.json --variant C0 --fidelity draft --out "$OUT/$2" --no-db --threads 2 \
    --quiet > "$OUT/$2.log" 2>&1
  t1=$(date +%s.%N)
  awk "BEGIN{printf \"%.2f\", $t1 - $t0}"
}
for r in $(seq "$ROUNDS"); do
  order="OLD NEW"; [ $((r % 2)) = 0 ] && order="NEW OLD"  # the order swapped every other round
  for w in $order; do d=${!w}; echo "round $r $w dam break 2 threads: $(dam "$d" 2)" | tee -a "$OUT/results.txt"; done
  for w in $order; do d=${!w}; echo "round $r $w flume C0 draft 2 threads: $(flume "$d" "$w-$r") s" | tee -a "$OUT/results.txt"; done
  for w in $order; do d=${!w}; echo "round $r $w dam break 1 thread: $(dam "$d" 1)" | tee -a "$OUT/results.txt"; done
done
