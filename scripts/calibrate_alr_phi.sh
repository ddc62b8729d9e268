#!/bin/sh
# The Alr catchment's material calibration on G0 (docs/study.md, "Alr catchment: design basis"): G0 (no dam) of
# scenarios/catchment/alr.json run at a fidelity for each friction angle given, one run per angle, each in
# OUT/phi<angle>/ (metrics.json: terrain.inundation.runout_m, centre_of_mass, ...).
# Usage: scripts/calibrate_alr_phi.sh RUNOUT_BINARY OUT FIDELITY PHI... (e.g. build/runout /tmp/cal draft 17 19 21)
set -eu
runout=$(realpath "$1"); out=$(realpath -m "$2"); fidelity=$3; shift 3
here=$(cd "$(dirname "$0")/.." && pwd)
mkdir -p "$out"
for phi in "$@"; do
  scene="$out/alr_g0_phi$phi.json"
  /usr/bin/python3 - "$here/scenarios/catchment/alr.json" "$scene" "$phi" <<'PY'
import json, os, sys
src, dst, phi = sys.argv[1], sys.argv[2], float(sys.argv[3])
s = json.load(open(src))
s["name"] = "alr-g0-phi%g" % phi
s["structures"] = []
s["materials"][0]["friction_angle"] = phi
s["terrain"]["dem"] = os.path.normpath(os.path.join(os.path.dirname(src), s["terrain"]["dem"]))
json.dump(s, open(dst, "w"), indent=1)
PY
  OMP_NUM_THREADS=${OMP_NUM_THREADS:-1} "$runout" run "$scene" --fidelity "$fidelity" --out "$out/phi$phi" --no-db -q -j1
done
