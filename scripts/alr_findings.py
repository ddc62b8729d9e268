#!/usr/bin/env python3
"""The Alr catchment study's table and the thesis' findings (docs/study.md, "Alr catchment": declared 2026-12-06
before G4-G7 had finished at draft), from the runs' metrics.json.

    scripts/alr_findings.py RUNS_DIR [SCREENING_RUNS_DIR]

RUNS_DIR holds G0..G7 (runs/alr-G0-G7 of `runout sweep scenarios/catchment/alr_g0_g7.json`). With a second folder
(the same sweep at another rung, e.g. --fidelity screening) it prints the Kendall tau of the two rankings: on the
arrivals always, on depth, peak discharge, area and runout only when every run of both came to rest (a run cut
short, as the arrival ladder's, has its final arrivals but not its final extent).

The findings, as tested (G1 = Dam1, G2 = Dam2, G3 = Dam3, G4 = Dam1+2, G5 = Dam1+3, G6 = Dam2+3, G7 = all):
  F1  a dam delays the front and lowers Q_m below it: at the section 30 m below the dam (S1, S2, S3 for Dam1..3),
      its single-dam layout's arrival is later and its peak discharge lower than G0's.
  F2  downstream dams do more than upstream ones: the Village's max depth and S3's peak discharge order
      G3 <= G2 <= G1.
  F3  several dams more than one: G7's Village max depth and S3 peak discharge below each single-dam layout's.
  F4  upstream dams take higher loads: in G7, Dam1's peak force > Dam2's > Dam3's.
Each is printed with the differences it rests on and judged against the rung's resolution of the metric, fixed
here from the numerics, not from the results: a peak discharge is counted in whole particles per discharge window,
so it moves in quanta of dp^3 / window (64 m^3 / 0.90 s = 71 m^3/s at draft); a max depth resolves a particle
layer, dp. A difference inside that is "unresolved"; arrivals are resolved to the series' sampling. The issue's
margin, the metric's draft-standard difference, needs the standard rung; until it runs, a finding holds "at draft".
"""
import json
import os
import sys

LAYOUTS = [f"G{k}" for k in range(8)]
DAMS = {"G1": ["Dam1"], "G2": ["Dam2"], "G3": ["Dam3"], "G4": ["Dam1", "Dam2"], "G5": ["Dam1", "Dam3"],
        "G6": ["Dam2", "Dam3"], "G7": ["Dam1", "Dam2", "Dam3"], "G0": []}


def load(runs):
    out = {}
    for g in LAYOUTS:
        p = os.path.join(runs, g, "metrics.json")
        if os.path.exists(p):
            with open(p) as f:
                out[g] = json.load(f)
    return out


def row(m):
    sec = {x["name"]: x for x in m.get("monitors", []) if x.get("type") == "section"}
    loads = {x["name"]: x for x in m.get("monitors", []) if x.get("type") == "structure_load"}
    t = m["terrain"]
    village = next(z for z in t["protected_zones"] if z["name"] == "Village")
    window = next((x["discharge_window_s"] for x in sec.values() if "discharge_window_s" in x), None)
    if "screening" in m:  # particles of equal volume in plan; the depth is a kernel sum, not a layer count
        n = m["particles"]["fluid_final"] or 1
        particle, layer = m["screening"]["release_volume_m3"] / n, 0.0
        sampling = m["screening"]["output_interval_s"]  # its sections are sampled at the output interval
    else:
        layer = m["settings"]["dp_m"]
        particle = layer ** 3
        sampling = m["dt"]["last_s"]  # a 3D section times a crossing to its step
    r = {"status": m["status"], "at_rest": m.get("rest", {}).get("ended_at_s") is not None, "dp": layer, "q_quantum": particle / window if window else 0.0, "sampling": sampling, "runout": t["inundation"]["runout_m"], "area": t["inundation"]["inundated_area_m2"],
         "village_arrival": village.get("arrival_time_s"), "village_depth": village.get("max_depth_m"),
         "village_area": village.get("inundated_area_m2")}
    for s in ("S1", "S2", "S3"):
        x = sec.get(s, {})
        r[s + "_t0"] = x.get("arrival_time_s")
        r[s + "_Q"] = x.get("peak_discharge_m3_s")
        r[s + "_V"] = x.get("volume_passed_m3")
    for st in t["structures"]:
        r[st["name"] + "_retained"] = st.get("retained_volume_m3")
        if "screening_load" in st:
            r[st["name"] + "_F"] = st["screening_load"].get("peak_force_n")
    for name, x in loads.items():
        r[name + "_F"] = x.get("peak_force_n")
    return r


def fmt(v):
    if v is None:
        return "–"
    if isinstance(v, str):
        return v
    return f"{v:.4g}"


def table(rows):
    keys = ["status", "S1_t0", "S1_Q", "S2_t0", "S2_Q", "S3_t0", "S3_Q", "S3_V", "Dam1_F", "Dam2_F", "Dam3_F",
            "Dam1_retained", "Dam2_retained", "Dam3_retained", "area", "runout", "village_arrival",
            "village_depth", "village_area"]
    gs = [g for g in LAYOUTS if g in rows]
    print("| metric | " + " | ".join(gs) + " |")
    print("|---|" + "---|" * len(gs))
    for k in keys:
        print(f"| {k} | " + " | ".join(fmt(rows[g].get(k)) for g in gs) + " |")


def pct(a, b):
    return 100.0 * (a - b) / b if b else float("nan")


def verdict(better, margin):
    """better: how much the finding's side wins by (positive: as the thesis says)."""
    if abs(better) <= margin * (1 + 1e-9):  # one quantum is one particle: not resolved
        return "unresolved"
    return "holds" if better > 0 else "reversed"


def findings(r):
    if not all(g in r for g in ("G0", "G1", "G2", "G3", "G7")):
        print("findings: they need G0, G1, G2, G3 and G7")
        return
    g0 = r["G0"]
    print("\nF1: a dam delays the front and lowers Q_m below it")
    for g, s in (("G1", "S1"), ("G2", "S2"), ("G3", "S3")):
        dt = r[g][s + "_t0"] - g0[s + "_t0"]
        dq = pct(r[g][s + "_Q"], g0[s + "_Q"])
        q = g0[s + "_Q"] - r[g][s + "_Q"]
        print(f"  {g} at {s}: arrival {dt:+.2f} s -> {verdict(dt, g0['sampling'])}; peak discharge {dq:+.1f} % "
              f"({-q:+.4g} m3/s, quantum {g0['q_quantum']:.3g}) -> {verdict(q, g0['q_quantum'])}")
    for k, label, margin in (("village_depth", "Village max depth", g0["dp"]),
                             ("S3_Q", "S3 peak discharge", g0["q_quantum"])):
        v = [r[g][k] for g in ("G1", "G2", "G3")]
        print(f"F2 ({label}, resolution {margin:.3g}): G1 {v[0]:.4g}, G2 {v[1]:.4g}, G3 {v[2]:.4g}: "
              f"G3 below G2 -> {verdict(v[1] - v[2], margin)}; G2 below G1 -> {verdict(v[0] - v[1], margin)}")
        w = r["G7"][k]
        print(f"F3 ({label}): G7 {w:.4g} against G1-G3 {v[0]:.4g} / {v[1]:.4g} / {v[2]:.4g} -> "
              + ", ".join(verdict(x - w, margin) for x in v))
    f = [r["G7"].get(d + "_F") for d in ("Dam1", "Dam2", "Dam3")]
    if None not in f:
        print(f"F4: G7 peak force Dam1 {f[0]:.4g} N, Dam2 {f[1]:.4g} N, Dam3 {f[2]:.4g} N -> "
              f"{'holds' if f[0] > f[1] > f[2] else 'does not hold'} (no resolution declared for a force)")


def kendall_tau(a, b):
    """Kendall's tau-b of two score lists (ties counted as neither concordant nor discordant)."""
    n, c, d, ta, tb = len(a), 0, 0, 0, 0
    for i in range(n):
        for j in range(i + 1, n):
            x, y = a[i] - a[j], b[i] - b[j]
            if x == 0 and y == 0:
                continue
            if x == 0:
                ta += 1
            elif y == 0:
                tb += 1
            elif (x > 0) == (y > 0):
                c += 1
            else:
                d += 1
    den = ((c + d + ta) * (c + d + tb)) ** 0.5
    return (c - d) / den if den else float("nan")


def main():
    r = {g: row(m) for g, m in load(sys.argv[1]).items()}
    table(r)
    findings(r)
    if len(sys.argv) > 2:
        s = {g: row(m) for g, m in load(sys.argv[2]).items()}
        both = [g for g in LAYOUTS if g in r and g in s]
        # Arrivals are final in a run cut short (they are causal); depths, peaks and extents only at rest.
        final = all(r[g]["at_rest"] and s[g]["at_rest"] for g in both)
        keys = ["S1_t0", "S2_t0", "S3_t0", "village_arrival"]
        keys += ["village_depth", "S3_Q", "area", "runout"] if final else []
        for k in keys:
            a = [r[g][k] for g in both]
            b = [s[g][k] for g in both]
            if None in a or None in b:
                continue
            print(f"Kendall tau ({k}, {len(both)} layouts, ranks of {sys.argv[1]} against {sys.argv[2]}): "
                  f"{kendall_tau(a, b):+.2f}")


if __name__ == "__main__":
    main()
