#!/usr/bin/env python3
"""Writes scenarios/flume/flume_dem.asc (+ .prj): the synthetic laboratory flume of the C0-C7 study.

A 38 degree chute 3 m long (plan) with a rectangular-ish channel 0.30 m wide between banks 0.20 m high,
then a 3 degree run-out plain 3.0 m long where the banks fade out and the flow spreads. Plan 6.0 m x 1.2 m,
2 cm cells, UTM 32N (EPSG:32632) with the lower-left corner at (500000, 5000000). Local coordinates in the
comments and in docs/study.md are metres from that corner: x downstream (east), y across (north), the
channel centre line at y = 0.6. Pure Python, no dependencies: `python3 scripts/make_flume_dem.py`.
"""
import argparse
import math
import os

CELL = 0.02
NX, NY = 300, 60            # 6.0 m x 1.2 m
X0, Y0 = 500000.0, 5000000.0
X_KINK = 3.0                # chute foot (plan distance from the top)
Z_KINK = 0.5                # its elevation
CHUTE = math.radians(38.0)
PLAIN = math.radians(3.0)
BLEND = 0.15                # half-length of the rounded chute foot
Y_AXIS, HALF_WIDTH, BANK, BANK_RAMP = 0.6, 0.15, 0.20, 0.04


def smoothstep(t):
    t = min(1.0, max(0.0, t))
    return t * t * (3 - 2 * t)


def bed(x):
    # Chute and plain, joined by a parabola over [X_KINK - BLEND, X_KINK + BLEND] (slope changes linearly).
    s1, s2 = math.tan(CHUTE), math.tan(PLAIN)
    if x <= X_KINK - BLEND:
        return Z_KINK + (X_KINK - x) * s1
    if x >= X_KINK + BLEND:
        return Z_KINK - (x - X_KINK) * s2
    u = x - (X_KINK - BLEND)
    z0 = Z_KINK + BLEND * s1
    return z0 + (-s1 * u + 0.5 * (s1 - s2) * u * u / (2 * BLEND))


def elevation(x, y):
    z = bed(x)
    # Channel banks on the chute, fading out over the first 0.4 m of the plain.
    fade = 1.0 - smoothstep((x - X_KINK) / 0.4)
    z += fade * BANK * smoothstep((abs(y - Y_AXIS) - HALF_WIDTH) / BANK_RAMP)
    # A back wall above the release.
    if x < 0.06:
        z += 0.3
    return z


def main():
    global CHUTE
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--chute-deg", type=float, default=math.degrees(CHUTE), help="chute inclination [deg]")
    ap.add_argument("--out", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scenarios", "flume"),
                    help="directory for flume_dem.asc and .prj")
    args = ap.parse_args()
    CHUTE = math.radians(args.chute_deg)
    here = args.out
    lines = [f"ncols {NX}", f"nrows {NY}", f"xllcorner {X0:.3f}", f"yllcorner {Y0:.3f}", f"cellsize {CELL}",
             "NODATA_value -9999"]
    for r in range(NY):  # row 0 is the north edge
        y = (NY - r - 0.5) * CELL
        lines.append(" ".join(f"{elevation((c + 0.5) * CELL, y):.4f}" for c in range(NX)))
    with open(os.path.join(here, "flume_dem.asc"), "w") as f:
        f.write("\n".join(lines) + "\n")
    # ESRI WKT of WGS 84 / UTM zone 32N (what `gdalsrsinfo -o wkt_esri EPSG:32632` prints).
    prj = ('PROJCS["WGS_1984_UTM_Zone_32N",GEOGCS["GCS_WGS_1984",DATUM["D_WGS_1984",'
           'SPHEROID["WGS_1984",6378137.0,298.257223563]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]],'
           'PROJECTION["Transverse_Mercator"],PARAMETER["False_Easting",500000.0],PARAMETER["False_Northing",0.0],'
           'PARAMETER["Central_Meridian",9.0],PARAMETER["Scale_Factor",0.9996],PARAMETER["Latitude_Of_Origin",0.0],'
           'UNIT["Meter",1.0]]')
    with open(os.path.join(here, "flume_dem.prj"), "w") as f:
        f.write(prj + "\n")


if __name__ == "__main__":
    main()
