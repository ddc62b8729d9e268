#!/usr/bin/env bash
# Runs that share a machine (docs/performance.md, "Runs that share a machine"; issue 47 item 3): one flume layout
# at draft (C0 of the README's main job; SCENES="flume dambreak" adds the 2D dam break), alone with two threads and
# as two processes side by side with two threads each (a sweep beside a service, CI's tests two at a time), under
# OpenMP wait policies: libgomp's default (300 000 spins, then sleep), passive, and short spins
# (GOMP_SPINCOUNT=10000 and 1000). Alternating, REPEAT rounds. Run from the repository root on a quiet machine:
#   bench/share_machine.sh [BUILD_DIR] [OUT_DIR] [REPEAT]
set -uo pipefail
B=${1:-build}/runout
OUT=${2:-/tmp/share-machine-bench}
REPEAT=${3:-2}
CAP=120  # [s] a pair that has not finished by then is reported as "> CAP"
mkdir -p "$OUT"
: > "$OUT/results.txt"
declare -A POLICY=([default]="GOMP_SPINCOUNT=300000" [passive]="OMP_WAIT_POLICY=passive" [spin10k]="GOMP_SPINCOUNT=10000" [spin1k]="GOMP_SPINCOUNT=1000")
declare -A SCENE=([flume]="scenarios/flume/c0_c7.json --variant C0 --fidelity draft" [dambreak]="scenarios/validation/dam_break_2d.json")
one() {  # policy scene tag: prints the run's wall time [s], or CAP+ when it was cut
  local t0 t1
  t0=$(date +%s.%N)
  env ${POLICY[$1]} timeout $CAP "$B" run ${SCENE[$2]} --out "$OUT/$3" --no-db --threads 2 --quiet > "$OUT/$3.log" 2>&1 \
    || { echo "${CAP}+"; return; }
  t1=$(date +%s.%N)
  awk "BEGIN{printf \"%.1f\", $t1 - $t0}"
}
for r in $(seq "$REPEAT"); do
  for s in ${SCENES:-flume}; do
    for p in default passive spin10k spin1k; do
      alone=$(one $p $s "$s-$p-alone")
      one $p $s "$s-$p-a" > "$OUT/pa" & one $p $s "$s-$p-b" > "$OUT/pb" & wait
      echo "repeat $r $s $p alone $alone s pair $(cat "$OUT/pa") / $(cat "$OUT/pb") s" | tee -a "$OUT/results.txt"
    done
  done
done
