#!/usr/bin/env python3
"""Compares a 2D dam-break run's surge front with Martin & Moyce (1952) and Koshizuka & Oka (1996), with no
time shift: the numbers of docs/validation.md, section 2 (the same formulas as tests/engine/dam_break_test.cpp).

    scripts/dam_break_front.py --a A [--until S] RUN_DIR [RUN_DIR ...]

RUN_DIR is a `runout run` output of an n^2 = 2 column of width A metres (0.3 for dam_break_mm_2d.json, 1 for
dam_break_1x2_2d.json, at any dp); dp is read from RUN_DIR/metrics.json unless --dp is given. Front
Z = (front_x + dp/2)/a, T = t sqrt(2g/a). Prints the mean and worst |relative error| at the experiments' T,
and the lead: how much earlier in T the simulated front reached each measured position.
Tables: PySPH pysph/examples/db_exp_data.py and Lethe's dam-break-2d.py (docs/validation-data.md, section 3).
"""
import argparse
import csv
import json
import math
import os

MM = [(0.832, 1.217), (1.219, 1.474), (1.997, 2.292), (2.547, 2.995), (3.345, 4.134), (4.034, 4.944),
      (4.418, 5.881), (5.091, 6.980), (5.685, 7.945), (6.306, 8.966), (6.822, 9.986), (7.439, 10.963),
      (8.031, 11.977), (8.633, 13.005), (9.237, 13.970),
      (0.41, 1.11), (0.84, 1.23), (1.19, 1.44), (1.43, 1.67), (1.63, 1.89), (1.82, 2.11), (1.97, 2.33),
      (2.2, 2.56), (2.32, 2.78), (2.5, 3.0), (2.64, 3.22), (2.82, 3.44), (2.96, 3.67)]
MM.sort()
KO = [(0.381, 1.111), (0.769, 1.252), (1.153, 1.505), (1.537, 1.892), (1.935, 2.241), (2.323, 2.615),
      (2.719, 3.003), (3.096, 3.624)]


def interp(s, T):
    for (t0, z0), (t1, z1) in zip(s, s[1:]):
        if t0 <= T <= t1:
            return z0 + (T - t0) / (t1 - t0) * (z1 - z0)
    return float("nan")


def errors(sim, ref, T0, T1):
    d = [(interp(sim, T) - Z) / Z for T, Z in ref if T0 <= T <= T1]
    d = [x for x in d if x == x]
    if not d:
        return float("nan"), float("nan"), 0
    return 100 * sum(map(abs, d)) / len(d), 100 * max(map(abs, d)), len(d)


def lead(sim, T, Z):
    for (t0, z0), (t1, z1) in zip(sim, sim[1:]):
        if z0 < Z <= z1:
            return T - (t0 + (Z - z0) / (z1 - z0) * (t1 - t0))
    return float("nan")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("runs", nargs="+")
    ap.add_argument("--a", type=float, required=True, help="column width [m]")
    ap.add_argument("--dp", type=float, help="particle spacing [m] (default: from metrics.json)")
    ap.add_argument("--g", type=float, default=9.81)
    ap.add_argument("--until", type=float, default=float("inf"),
                    help="compare only up to this simulated time [s] (before the front meets the far wall)")
    args = ap.parse_args()
    for run in args.runs:
        m = json.load(open(os.path.join(run, "metrics.json")))
        dp = args.dp or m["settings"]["dp_m"]
        a = args.a
        Ts = math.sqrt(2 * args.g / a)
        rows = [r for r in csv.DictReader(open(os.path.join(run, "series", "run.csv")))
                if float(r["t"]) <= args.until]
        sim = [(float(r["t"]) * Ts, (float(r["front_x"]) + dp / 2) / a) for r in rows]
        mm_mean, mm_worst, n_mm = errors(sim, MM, 1.0, 6.35)
        ko_mean, ko_worst, n_ko = errors(sim, KO, 1.0, 3.1)
        print(f"{run}: a = {a} m, dp = {dp} m, a/dp = {a / dp:.0f}, {m.get('steps', '?')} steps")
        print(f"  Martin & Moyce, T in [1, 6.35] ({n_mm} points): mean {mm_mean:.1f} %, worst {mm_worst:.1f} %")
        print(f"  Koshizuka & Oka, T in [1, 3.1] ({n_ko} points): mean {ko_mean:.1f} %, worst {ko_worst:.1f} %")
        print(f"  Z(T=2) {interp(sim, 2.0):.2f}, Z(T=3) {interp(sim, 3.0):.2f}, Z(T=6) {interp(sim, 6.0):.2f}")
        print("  lead in T over Martin & Moyce: " +
              " ".join(f"{T:.2f}:{lead(sim, T, Z):+.2f}" for T, Z in MM if T <= sim[-1][0]))


if __name__ == "__main__":
    main()
