#!/bin/bash
# The screening runs the cost model's screening term is fitted on (docs/tradeoff.md, "The screening rung's cost"):
# one thread, one at a time; run it on an otherwise idle machine, then `runout calibrate --db WORK/cal.db`.
# Usage: scripts/screening_cost_runs.sh BUILD_DIR WORK_DIR
set -euo pipefail
B=$(realpath "$1"); W=$(mkdir -p "$2" && realpath "$2"); S=$(realpath "$(dirname "$0")/../scenarios")
R="$B/runout"
/usr/bin/python3 - "$S" "$W" <<'PY'
import json, sys
S, W = sys.argv[1], sys.argv[2]
f = json.load(open(f"{S}/flume/flume.json")); f["terrain"]["dem"] = f"{S}/flume/flume_dem.asc"
a = json.load(open(f"{S}/catchment/alr.json")); a["terrain"]["dem"] = f"{S}/dem/alr_5m.tif"
a["materials"][0]["friction_angle"] = 14  # the screening rung's fit to Alr's basis (docs/tradeoff.md)
for name, scene, extra in [("flume_ref005", f, {"reference_spacing": 0.05}), ("flume_s002", f, {"spacing": 0.02}),
                           ("alr14", a, None)]:
    s = dict(scene)
    if extra: s["screening"] = extra
    json.dump(s, open(f"{W}/{name}.json", "w"))
    json.dump({"name": name, "base": f"{W}/{name}.json", "fidelity": "screening",
               "factorial": {"structures": ["Dam1", "Dam2", "Dam3"], "prefix": "G"}} if name == "alr14" else
              {"name": name, "base": f"{W}/{name}.json", "fidelity": "screening",
               "variants": [{"name": "C0", "structures": []}, {"name": "C3", "structures": ["CD_P2"]}]},
              open(f"{W}/{name}_sweep.json", "w"))
PY
run() { name=$1; shift; "$R" run "$@" --fidelity screening -j 1 -q --db "$W/cal.db" -o "$W/out/$name" || true; }
run flume-C0 "$S/flume/c0_c7.json" --variant C0
for v in C0 C3; do run ref005-$v "$W/flume_ref005_sweep.json" --variant $v; done
run s002-C0 "$W/flume_s002_sweep.json" --variant C0
run jackhyd-G7 "$S/catchment/g0_g7_hydrograph.json" --variant G7
for v in G0 G7; do run jack-$v "$S/catchment/g0_g7.json" --variant $v; done
run alr20-G0 "$S/catchment/alr_g0_g7.json" --variant G0
for v in G0 G7; do run alr14-$v "$W/alr14_sweep.json" --variant $v; done
"$B/runout" calibrate --db "$W/cal.db"
