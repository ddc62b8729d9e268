#!/usr/bin/env python3
"""SPHERIC Test 2: the runs that measure why the face pressure is wrong (docs/validation.md section 7.1).

    scripts/spheric2_causes.py make OUT_DIR [ROWS]  # writes OUT_DIR/{base,extrap,av10,c100}.json
    build/runout run OUT_DIR/base.json --out OUT_DIR/base --no-db --threads 2 --quiet --snapshots   # each
    scripts/spheric2_causes.py read RUN_DIR         # the table's figures for one run

Each scene is scenarios/validation/spheric2_3d.json run to 1.0 s with snapshots every 0.05 s, the fluid probes at
every sensor height at face + 0.5 h (P1a..), face + h (P1.., the test's) and face + 2 h (P1c..), the face sensors
(face_pressure, on the face) at the same heights, and one change: none, extrapolated walls, alpha 0.1, c0 100 m/s.
ROWS (default 15, the scene's) sets dp = 0.55 / ROWS; the box is then laid as the nearest whole spacings from its
front face (x = 0.8245 m) back, across and up (at 20: 6 x 15 x 6 spacings, 0.165 x 0.4125 x 0.165 m).
Read with the test's formulas (tests/engine/spheric2_test.cpp): the experiment's zero offset (mean before 0.35 s)
removed, the peak of the 11-sample (10 ms) centred moving average over 0-0.55 s, the mean over 0.495-0.995 s.
Needs numpy (Debian python3-numpy).
"""
import copy
import csv
import json
import os
import sys

import numpy as np

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
FACE_X = 0.8245
HEIGHTS = [0.021, 0.061, 0.101, 0.141]
VARIANTS = {"base": {}, "extrap": {"boundary_pressure": "extrapolated"}, "av10": {"artificial_viscosity": 0.1},
            "c100": {"speed_of_sound": 100}}


def make(out_dir, rows=15):
    base = json.load(open(os.path.join(ROOT, "scenarios/validation/spheric2_3d.json")))
    if rows != 15:
        dp = 0.55 / rows
        base["dp"] = dp
        nx, ny, nz = round(0.161 / dp), round(0.403 / dp), round(0.161 / dp)
        box = next(b for b in base["boundaries"] if b["tag"] == "box")
        box["min"] = [FACE_X - nx * dp, 0.5 - ny * dp / 2, 0]
        box["max"] = [FACE_X, 0.5 + ny * dp / 2, nz * dp]
    os.makedirs(out_dir, exist_ok=True)
    for name, numerics in VARIANTS.items():
        s = copy.deepcopy(base)
        s["name"], s["duration"] = name, 1.0
        s["numerics"].update(numerics)
        h = s["numerics"]["smoothing_ratio"] * s["dp"]
        mons = [m for m in s["monitors"] if m["type"] not in ("pressure_probe", "face_pressure")]
        for i, z in enumerate(HEIGHTS):
            for tag, off in (("a", 0.5 * h), ("", h), ("c", 2 * h)):
                mons.append({"type": "pressure_probe", "name": f"P{i + 1}{tag}", "point": [FACE_X + off, 0.5, z],
                             "wet_kernel_sum": 0.25})
            mons.append({"type": "face_pressure", "name": f"F{i + 1}", "structure": "box", "point": [FACE_X, 0.5, z],
                         "normal": [-1, 0, 0]})
        s["monitors"] = mons
        s["output"]["snapshot_interval"] = 0.05
        json.dump(s, open(os.path.join(out_dir, name + ".json"), "w"), indent=1)


def load(path):
    rows = list(csv.reader(r for r in open(path) if not r.startswith("#")))
    data = np.array([[float(x) for x in row] for row in rows[1:]])
    return {k: data[:, i] for i, k in enumerate(rows[0])}


def window_mean(t, v, lo, hi):
    m = (t >= lo) & (t < hi)
    return v[m].mean() if m.any() else float("nan")


def peak_10ms(t, v, lo, hi):
    """Peak of the 11-sample centred moving average (10 ms at 1 kHz) for t in [lo, hi], and its time: the test's."""
    best, when = -1e30, 0.0
    for i in range(5, len(t) - 5):
        if lo <= t[i] <= hi and v[i - 5:i + 6].mean() > best:
            best, when = v[i - 5:i + 6].mean(), t[i]
    return best, when


def first_over(t, v, x):
    return t[np.argmax(v > x)] if (v > x).any() else float("nan")


def read(run_dir):
    e10 = load(os.path.join(ROOT, "tests/data/spheric2_exp_10ms.csv"))
    e1k = load(os.path.join(ROOT, "tests/data/spheric2_exp_impact_1khz.csv"))
    print(run_dir)
    for k in range(4):
        col = f"p{k + 1}_pa"
        zero = window_mean(e10["t"], e10[col], -1, 0.35)
        pe, pe10 = e1k[col] - zero, e10[col] - zero
        pk_e, tpk_e = peak_10ms(e1k["t"], pe, 0, 0.55)
        mean_e = window_mean(e10["t"], pe10, 0.495, 0.995)
        for name, file in ((f"P{k + 1}a", f"pressure_probe_P{k + 1}a"), (f"P{k + 1}", f"pressure_probe_P{k + 1}"),
                           (f"P{k + 1}c", f"pressure_probe_P{k + 1}c"), (f"F{k + 1}", f"face_pressure_F{k + 1}")):
            path = os.path.join(run_dir, "series", file + ".csv")
            if not os.path.exists(path):
                continue
            s = load(path)
            t, p = s["t"], s["pressure_pa"]
            pk, tpk = peak_10ms(t, p, 0, 0.55)
            mean = window_mean(t, p, 0.495, 0.995)
            late = (t > 0.5) & (t < 1.0)
            neg = ((p < 0) & late).sum() / late.sum()
            print(f"  {name:4s} first > 1 kPa {first_over(t, p, 1000):.3f} (exp {first_over(e1k['t'], pe, 1000):.3f}) s;"
                  f" 10 ms peak {pk / 1e3:5.1f} kPa at {tpk:.3f} s (exp {pk_e / 1e3:4.1f} at {tpk_e:.3f}) "
                  f"{100 * (pk / pk_e - 1):+5.0f} %; mean 0.495-0.995 s {mean / 1e3:5.2f} kPa (exp {mean_e / 1e3:4.2f}) "
                  f"{100 * (mean / mean_e - 1):+5.0f} %; under 0: {100 * neg:.0f} %")
    b = load(os.path.join(run_dir, "series", "structure_load_box.csv"))
    print(f"  box: mean force 0.5-1.0 s {window_mean(b['t'], b['force_n'], 0.5, 1.0):.0f} N, mean pressure "
          f"{window_mean(b['t'], b['mean_pressure_pa'], 0.5, 1.0):.0f} Pa")


if __name__ == "__main__":
    if len(sys.argv) not in (3, 4) or sys.argv[1] not in ("make", "read"):
        sys.exit(__doc__)
    if sys.argv[1] == "make":
        make(sys.argv[2], int(sys.argv[3]) if len(sys.argv) == 4 else 15)
    else:
        read(sys.argv[2])
