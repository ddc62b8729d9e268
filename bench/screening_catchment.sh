#!/usr/bin/env bash
# The screening rung on the Alr catchment (issue 44's bench: a layout at 5 m in <= 10 s on two cores, G0-G7 in
# <= 1 minute; docs/performance.md, "The screening rung on a catchment"). Runs scenarios/catchment/alr_g0_g7.json
# at --fidelity screening with the particles' plan spacing (screening.spacing) set to each DP (the scene's dp, the
# bed grid's spacing, stays 2 m: a dp of 5 m would refuse the 4 m deep hydrograph), one layout at a time with THREADS OpenMP threads, and prints each layout's wall time (the run, from its
# metrics.json), its particles and steps, and the whole sweep's wall time. Run from the repository root of a
# Release build on a quiet machine:
#   [JOBS=1] bench/screening_catchment.sh [BUILD_DIR] [OUT_DIR] [THREADS] [DP ...]
# (defaults: build /tmp/screening-bench 2 5; JOBS layouts at once, THREADS threads each).
set -euo pipefail
B=$(realpath "${1:-build}")/runout
OUT=${2:-/tmp/screening-bench}
THREADS=${3:-2}
JOBS=${JOBS:-1}
shift $(( $# > 3 ? 3 : $# ))
SPACINGS=("${@:-5}")
ROOT=$(pwd)
mkdir -p "$OUT"
for dp in "${SPACINGS[@]}"; do
  dir="$OUT/dp$dp"
  rm -rf "$dir" && mkdir -p "$dir"
  # The scene with its DEM path made absolute and the screening preset at this dp; the sweep file beside it.
  /usr/bin/python3 - "$ROOT" "$dir" "$dp" <<'EOF'
import json, os, sys
root, out, dp = sys.argv[1], sys.argv[2], float(sys.argv[3])
cat = os.path.join(root, "scenarios", "catchment")
scene = json.load(open(os.path.join(cat, "alr.json")))
scene["terrain"]["dem"] = os.path.normpath(os.path.join(cat, scene["terrain"]["dem"]))
for s in scene.get("structures", []) + scene.get("protected_zones", []):
    for key in ("layer", "file"):
        if isinstance(s.get(key), str):
            s[key] = os.path.normpath(os.path.join(cat, s[key]))
scene.setdefault("screening", {})["spacing"] = dp
json.dump(scene, open(os.path.join(out, "alr.json"), "w"), indent=1)
sweep = json.load(open(os.path.join(cat, "alr_g0_g7.json")))
sweep["base"] = "alr.json"
sweep["fidelity"] = "screening"
json.dump(sweep, open(os.path.join(out, "sweep.json"), "w"), indent=1)
EOF
  t0=$(date +%s.%N)
  "$B" sweep "$dir/sweep.json" --jobs "$JOBS" --threads "$THREADS" --db "$dir/runout.db" --out "$dir/runs" > "$dir/sweep.log" 2>&1
  t1=$(date +%s.%N)
  /usr/bin/python3 - "$dir/runs" "$dp" "$THREADS" "$(awk "BEGIN{print $t1 - $t0}")" "$JOBS" <<'EOF'
import json, pathlib, sys
runs, dp, threads, total, jobs = pathlib.Path(sys.argv[1]), sys.argv[2], sys.argv[3], float(sys.argv[4]), sys.argv[5]
rows = sorted(runs.rglob("metrics.json"))
print(f"dp {dp} m, {threads} threads a run, {jobs} at once: {len(rows)} layouts, sweep wall {total:.1f} s")
for m in rows:
    j = json.load(open(m))
    print(f"  {m.parent.name:28s} {j['status']:10s} wall {j['wall_time_s']:7.2f} s  particles "
          f"{j['particles']['fluid_final']:6d}  steps {j['steps']:6d}  simulated {j['simulated_time_s']:7.1f} s")
EOF
done
