#!/usr/bin/env bash
# The MPI sweep benchmark of docs/performance.md ("MPI sweeps"): the C0-C7 flume sweep at draft with 1, 2, 3
# and 4 ranks and, for comparison, without mpirun (--jobs 2), each on a fresh store. Run from the repository
# root on a quiet machine:   bench/mpi_sweep_bench.sh [BUILD_DIR] [OUT_DIR]
set -euo pipefail
B=${1:-build}/runout
OUT=${2:-/tmp/mpi-sweep-bench}
M="mpirun --allow-run-as-root --oversubscribe --bind-to none"
mkdir -p "$OUT"
: > "$OUT/results.txt"
timed() {  # name, command...
  local name=$1; shift
  rm -rf "${OUT:?}/$name"; mkdir -p "$OUT/$name"
  local t0 t1 rc=0
  t0=$(date +%s.%N)
  "$@" --db "$OUT/$name/runout.db" --out "$OUT/$name/runs" --no-compare > "$OUT/$name/log" 2>&1 || rc=$?
  t1=$(date +%s.%N)
  echo "$name rc=$rc wall=$(awk "BEGIN{printf \"%.1f\", $t1 - $t0}") s" | tee -a "$OUT/results.txt"
}
S=scenarios/flume/c0_c7.json
timed np1x2 $M -np 1 "$B" sweep $S --fidelity draft --threads 2
timed np2x2 $M -np 2 "$B" sweep $S --fidelity draft --threads 2
timed np3x1 $M -np 3 "$B" sweep $S --fidelity draft --threads 1
timed np4x1 $M -np 4 "$B" sweep $S --fidelity draft --threads 1
timed jobs2 "$B" sweep $S --fidelity draft --jobs 2
