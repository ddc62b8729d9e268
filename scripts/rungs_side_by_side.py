#!/usr/bin/env python3
"""Each layout's decision metrics at several rungs of one sweep, side by side, from a run store
(docs/tradeoff.md, "Screening against 3D on the flume"): the latest run of each variant at each fidelity, its
status, and for each metric the value at each rung and each rung's deviation in per cent from the last (the
reference rung). A failed run shows its status and no values.

    scripts/rungs_side_by_side.py DB SWEEP FIDELITY [FIDELITY ...]
    scripts/rungs_side_by_side.py runout.db flume-C0-C7 screening draft standard
"""
import signal
import sqlite3
import sys

signal.signal(signal.SIGPIPE, signal.SIG_DFL)  # piped into head: stop quietly

METRICS = [  # name in the store, label
    ("monitors.section.Chute.arrival_time_s", "Chute arrival (s)"),
    ("monitors.section.Chute.peak_discharge_m3_s", "Chute Q_m (m3/s)"),
    ("monitors.section.Outlet.arrival_time_s", "Outlet arrival (s)"),
    ("monitors.section.Outlet.peak_discharge_m3_s", "Outlet Q_m (m3/s)"),
    ("monitors.section.Outlet.volume_passed_m3", "Outlet volume (m3)"),
    ("terrain.inundation.runout_m", "runout (m)"),
    ("terrain.inundation.inundated_area_m2", "inundated area (m2)"),
    ("terrain.protected_zones.Village.max_depth_m", "Village max depth (m)"),
]


def main():
    if len(sys.argv) < 4:
        sys.exit(__doc__)
    db, sweep, rungs = sys.argv[1], sys.argv[2], sys.argv[3:]
    con = sqlite3.connect(db)
    runs = {}  # (variant, fidelity) -> (id, status)
    for rid, variant, fidelity, status in con.execute(
            "SELECT id, variant, fidelity, status FROM runs WHERE sweep = ? ORDER BY id", (sweep,)):
        runs[(variant, fidelity)] = (rid, status)
    variants = sorted({v for v, _ in runs})
    ref = rungs[-1]
    for v in variants:
        print(f"{v}: " + ", ".join(f"{f} {runs.get((v, f), (0, 'missing'))[1]}" for f in rungs))
        values = {}
        for f in rungs:
            rid, status = runs.get((v, f), (None, "missing"))
            if status != "completed":
                continue
            values[f] = dict(con.execute("SELECT name, value FROM metrics WHERE run_id = ?", (rid,)).fetchall())
        for name, label in METRICS:
            row = []
            for f in rungs:
                x = values.get(f, {}).get(name)
                if x is None:
                    row.append(f"{f} -")
                    continue
                r = values.get(ref, {}).get(name)
                dev = f" ({100 * (x - r) / r:+.0f} %)" if f != ref and r not in (None, 0) and x >= 0 and r >= 0 else ""
                row.append(f"{f} {x:.4g}{dev}")
            print(f"  {label:24s} " + " | ".join(row))


if __name__ == "__main__":
    main()
