#!/usr/bin/env python3
"""Writes scenarios/validation/usgs_flume_wall_2d.json: the USGS debris-flow flume's 1994 vertical-wall tests
(Iverson, George & Logan 2016, JGR Earth Surface 121, doi:10.1002/2016JF003933) as a 2D slice per unit width.
Sources and the reading of each number: docs/validation-data.md section 5; the rules are here so the scene can be
rebuilt and checked, not edited by hand.

Geometry along the bed, s [m] from the head gate (the paper's x):
  * 31 deg to s = 74 m, easing to 2.4 deg between 74 and 84 m (the paper's section 3; drawn as five 2 m chords
    whose angles step linearly), then the 2.4 deg runout pad;
  * the wall: 2.4 m high, its face at s = 91.0 m, normal to the pad; the pad runs on 2 m past it, then the
    domain ends (material that overtops leaves);
  * the release: the sediment behind the head gate as D-Claw loads it for these tests (dlgeorge/flume,
    Obstacles/wall/progressive/maketopo.py, flume_eta: 4.7 m hopper, 1.9 m gate, a 3.3 m top at 17 deg below
    horizontal; its area 4.95 m2 per metre of width, 9.9 m3 over the flume's 2 m, the paper's "about 10 m3").
    The gate face is vertical; the top and the back are free surfaces. Fluid blocks are boxes, so the wedge is a
    stack of 0.1 m layers in the bed's frame, each spanning the wedge at its mid-height. The gate is not modelled:
    the release is instantaneous (the paper's gate opens in about 0.85 s). A back wall normal to the bed closes
    the hopper at s = -4.7 m.
The 3D scene (usgs_flume_wall_3d.json) is the same along the bed, across it: the flume 2 m wide between side walls
1.2 m high that end at s = 87.4 m (the paper's Table 1: extended for the wall tests), then a pad 12 m wide; the wall
5.2 m wide (Table 1), centred on the flume. The runup gauge is on the centreline (the paper's H).
Material: friction-HBP with the paper's phi_bed 28 deg and a bulk density from its solid fraction 0.64, grain
density 2700 kg/m3 and water: 0.64 * 2700 + 0.36 * 1000 = 2088 kg/m3; the pore-pressure ratio of a saturated
mixture at hydrostatic pore pressure, r_u = rho_w / rho = 1000 / 2088; the consistency, flow index and
regularisation of the studies' flume material (scenarios/flume/flume.json). Numerics: the scene's defaults.
"""
import json
import math
import pathlib

SLOPE, PAD = 31.0, 2.4
S_EASE0, S_EASE1, CHORDS = 74.0, 84.0, 5
S_WALL, WALL_H, WALL_T, S_END = 91.0, 2.4, 0.2, 93.0
S_BACK, LAYER = -4.7, 0.1
GAUGE_OFF_WALL = 0.3  # the runup gauge's distance from the wall's face: the kernel's reach 2h at dp 0.1
WIDTH, SIDEWALL_H, SIDEWALL_END = 2.0, 1.2, 87.4  # 3D: the flume's width, its side walls' height and end
PAD_WIDTH, WALL_W = 12.0, 5.2                      # 3D: the pad past the side walls, the wall across


def rad(a):
    return a * math.pi / 180


def segments():
    """(s0, length, angle) of each straight piece of the bed, downstream."""
    segs = [(S_BACK - 0.5, S_EASE0 - (S_BACK - 0.5), SLOPE)]
    step = (S_EASE1 - S_EASE0) / CHORDS
    for k in range(CHORDS):
        segs.append((S_EASE0 + k * step, step, SLOPE - (k + 0.5) * (SLOPE - PAD) / CHORDS))
    segs.append((S_EASE1, S_END - S_EASE1, PAD))
    return segs


def bed_point(s):
    """[x, z] of the bed at s; s = 0 (the gate) at the origin, upstream of it the first (31 deg) piece."""
    if s < 0:
        return [round(s * math.cos(rad(SLOPE)), 6), round(-s * math.sin(rad(SLOPE)), 6)]
    x = z = 0.0
    for s0, length, a in segments():
        start, end = max(s0, 0.0), min(s0 + length, s)
        if end > start:
            x += (end - start) * math.cos(rad(a))
            z -= (end - start) * math.sin(rad(a))
    return [round(x, 6), round(z, 6)]


def bed_frame_point(s, n, angle):
    x, z = bed_point(s)
    return [round(x + n * math.sin(rad(angle)), 6), round(z + n * math.cos(rad(angle)), 6)]


def wedge_layers():
    """The release as boxes in the 31 deg bed frame: (s_left, s_right, n0) of each 0.1 m layer."""
    hmax, top, top_angle, hopper = 1.9, 3.3, 17.0, -S_BACK
    s2 = -hmax * math.sin(rad(SLOPE))             # the gate's top, in bed coordinates (D-Claw's x2, y2)
    n2 = hmax * math.cos(rad(SLOPE))
    s1 = s2 - top * math.cos(rad(SLOPE - top_angle))  # the top's upstream end (x1, y1)
    n1 = n2 - top * math.sin(rad(SLOPE - top_angle))
    def left(n):
        return -hopper + (s1 + hopper) * n / n1 if n <= n1 else s1 + (s2 - s1) * (n - n1) / (n2 - n1)
    def right(n):
        return s2 * n / n2  # the vertical gate
    layers, n0 = [], 0.0
    while n0 + LAYER <= n2 + 1e-9:
        m = n0 + LAYER / 2
        layers.append((left(m), right(m), n0))
        n0 += LAYER
    area = 0.5 * abs((s1 - -hopper) * n1) + 0.5 * (n1 + n2) * (s2 - s1) + 0.5 * (0 - s2) * n2
    return layers, area


def scene():
    layers, area = wedge_layers()
    fluid = [{"origin": bed_frame_point(a, n0, SLOPE), "size": [round(b - a, 6), LAYER], "angle": SLOPE,
              "material": "debris"} for a, b, n0 in layers]
    placed = sum((b - a) * LAYER for a, b, _ in layers)
    bounds = [{"type": "plane", "tag": f"bed{k}", "origin": bed_point(s0), "length": round(length, 6),
               "angle": round(a, 6)} for k, (s0, length, a) in enumerate(segments())]
    bounds.append({"type": "block", "tag": "hopper_back", "origin": bed_point(S_BACK - WALL_T),
                   "size": [WALL_T, 2.5], "angle": SLOPE})
    bounds.append({"type": "block", "tag": "wall", "origin": bed_point(S_WALL), "size": [WALL_T, WALL_H],
                   "angle": PAD})
    gauges = [{"type": "depth_gauge", "name": f"x{int(s)}", "point": bed_point(s)} for s in (32, 66)]
    gauges.append({"type": "depth_gauge", "name": "runup", "point": bed_point(S_WALL - GAUGE_OFF_WALL)})
    monitors = gauges + [{"type": "structure_load", "name": "wall", "structure": "wall",
                          "normal": [round(math.cos(rad(PAD)), 6), round(-math.sin(rad(PAD)), 6)]}]
    lo, hi = bed_point(S_END), bed_point(S_BACK - 1)
    return {
        "name": "usgs-flume-wall-2d",
        "description": (
            "The USGS debris-flow flume's vertical-wall tests of 21 and 23 June 1994 (Iverson, George & Logan 2016, "
            "JGR Earth Surface 121, doi:10.1002/2016JF003933), a 2D slice per unit width, written by "
            "scripts/make_usgs_flume_scene.py (its docstring gives each number's source). The bed: 31 deg to "
            "s = 74 m from the head gate, easing to 2.4 deg by 84 m (five chords), the 2.4 deg pad to the wall, "
            "2.4 m high with its face at s = 91 m. The release: D-Claw's hopper wedge for these tests "
            f"(4.95 m2 per metre, 9.9 m3 over 2 m; placed as 0.1 m layers, {placed:.2f} m2), released at once "
            "(the gate is not modelled). Material: friction-HBP, phi 28 deg (the paper's phi_bed), rho 2088 "
            "kg/m3 (solid fraction 0.64 of 2700 kg/m3 grains in water), pore-pressure ratio rho_w / rho "
            "(hydrostatic; the measured flows carry more, docs/validation.md), the studies' mu 1 Pa s, n 1.05, "
            "m 100 s. Depth gauges at s = 32 and 66 m (the Iverson et al. 2010 cross-sections) and 0.3 m before "
            "the wall's face (the runup); the wall's load. Used by tests/scenarios/usgs_flume_test.cpp."),
        "dimensions": 2,
        "dp": 0.1,
        "duration": 14.0,
        "materials": [{"name": "debris", "rheology": "friction-hbp", "density": 2088, "viscosity": 1.0,
                       "flow_index": 1.05, "regularisation": 100, "friction_angle": 28, "cohesion": 0,
                       "pore_pressure_ratio": round(1000 / 2088, 6)}],
        "fluid": fluid,
        "boundaries": bounds,
        "domain": {"min": [round(hi[0] - 1, 3), round(lo[1] - 1, 3)], "max": [round(lo[0] + 0.5, 3),
                   round(hi[1] + 4, 3)], "outflow": ["x+", "bottom"]},
        "monitors": monitors,
        "output": {"series_interval": 0.01},
    }, area, placed


def with_y(p, y):
    return [p[0], y, p[1]]


def scene_3d(s2):
    """The 2D scene made 3D: the flume 2 m wide with its side walls to s = 87.4 m, a wide pad past them."""
    s = json.loads(json.dumps(s2))
    s["name"] = "usgs-flume-wall-3d"
    s["dimensions"] = 3
    s["description"] = s2["description"].replace("a 2D slice per unit width", "in 3D: the flume 2 m wide with "
        "side walls 1.2 m high to s = 87.4 m, then a 12 m wide pad; the wall 5.2 m wide, centred").replace(
        "per metre, 9.9 m3 over 2 m", "per metre, 9.9 m3 over the 2 m width").replace(
        "tests/scenarios/usgs_flume_test.cpp", "docs/validation.md section 13 (a measurement, not in CI)")
    for b in s["fluid"]:
        b["origin"] = with_y(b["origin"], 0.0)
        b["size"] = [b["size"][0], WIDTH, b["size"][1]]
    bounds = []
    for k, (s0, length, a) in enumerate(segments()):
        end = min(s0 + length, SIDEWALL_END)
        if end > s0:
            bounds.append({"type": "flume", "tag": f"bed{k}", "origin": with_y(bed_point(s0), 0.0),
                           "length": round(end - s0, 6), "angle": round(a, 6), "width": WIDTH,
                           "wall_height": SIDEWALL_H})
    y0 = WIDTH / 2 - PAD_WIDTH / 2
    bounds.append({"type": "plane", "tag": "pad", "origin": with_y(bed_point(SIDEWALL_END), y0),
                   "length": round(S_END - SIDEWALL_END, 6), "angle": PAD, "width": PAD_WIDTH})
    bounds.append({"type": "block", "tag": "hopper_back", "origin": with_y(bed_point(S_BACK - WALL_T), 0.0),
                   "size": [WALL_T, WIDTH, 2.5], "angle": SLOPE})
    bounds.append({"type": "block", "tag": "wall", "origin": with_y(bed_point(S_WALL), WIDTH / 2 - WALL_W / 2),
                   "size": [WALL_T, WALL_W, WALL_H], "angle": PAD})
    s["boundaries"] = bounds
    for m in s["monitors"]:
        if "point" in m:
            m["point"] = with_y(m["point"], WIDTH / 2)
        if "normal" in m:
            m["normal"] = [m["normal"][0], 0.0, m["normal"][1]]
    d = s["domain"]
    d["min"] = [d["min"][0], y0 - 1, d["min"][1]]
    d["max"] = [d["max"][0], y0 + PAD_WIDTH + 1, d["max"][1]]
    d["outflow"] = ["x+", "bottom", "y-", "y+"]
    return s


if __name__ == "__main__":
    s, area, placed = scene()
    out = pathlib.Path(__file__).resolve().parents[1] / "scenarios" / "validation" / "usgs_flume_wall_2d.json"
    out.write_text(json.dumps(s, indent=1) + "\n")
    print(f"{out}: wedge {area:.3f} m2, placed {placed:.3f} m2, {len(s['fluid'])} layers")
    out3 = out.with_name("usgs_flume_wall_3d.json")
    out3.write_text(json.dumps(scene_3d(s), indent=1) + "\n")
    print(out3)
