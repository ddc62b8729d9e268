#!/usr/bin/python3
"""The Alr catchment's design basis from its terrain (docs/study.md, "Alr catchment: design basis"): the channel's
profile along AvaFrame's path line, the site rules' stations and lines, and Rickenmann's (1999) toe.
Needs Debian's python3-numpy and gdal-bin. Usage: scripts/alr_design_basis.py (from the repository root)."""
import json, os, subprocess, tempfile
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DEM = os.path.join(ROOT, "scenarios/dem/alr_5m.tif")
PATH = os.path.join(ROOT, "scenarios/dem/alr_path.geojson")


def read_dem():
    with tempfile.TemporaryDirectory() as tmp:
        asc = os.path.join(tmp, "dem.asc")
        subprocess.run(["gdal_translate", "-q", "-of", "AAIGrid", DEM, asc], check=True)
        with open(asc) as fh:
            hdr = {}
            for _ in range(6):
                k, v = fh.readline().split()
                hdr[k.lower()] = float(v)
            z = np.loadtxt(fh)
    return hdr, np.where(z < -9000, np.nan, z)


HDR, Z = read_dem()


def ground(x, y):  # the 5 m cell under (x, y)
    cs, x0, y0 = HDR["cellsize"], HDR["xllcorner"], HDR["yllcorner"]
    i = int(round(Z.shape[0] - 1 - ((y - y0) / cs - 0.5)))
    j = int(round((x - x0) / cs - 0.5))
    return Z[i, j] if 0 <= i < Z.shape[0] and 0 <= j < Z.shape[1] else np.nan


line = np.array(json.load(open(PATH))["features"][0]["geometry"]["coordinates"])[:, :2]
tail = line[-1] - line[-2]
line = np.vstack([line, line[-1] + tail / np.linalg.norm(tail) * 700])  # on to the DEM's edge
S = np.concatenate([[0], np.cumsum(np.hypot(*np.diff(line, axis=0).T))])


def frame(s):  # point, downhill tangent, normal at s m of path
    p = np.array([np.interp(s, S, line[:, 0]), np.interp(s, S, line[:, 1])])
    q = np.array([np.interp(s + 10, S, line[:, 0]), np.interp(s + 10, S, line[:, 1])])
    t = (q - p) / np.linalg.norm(q - p)
    return p, t, np.array([-t[1], t[0]])


def cross(s):  # offsets -150..150 m, ground, index of the thalweg (lowest within 25 m of the path)
    c, _, n = frame(s)
    offs = np.arange(-150.0, 151.0, 1.0)
    zc = np.array([ground(*(c + o * n)) for o in offs])
    k = int(np.nanargmin(np.where(np.abs(offs) <= 25, zc, np.nan)))
    return c, n, offs, zc, k


def span(offs, zc, k, level):  # the run of ground below `level` around the thalweg; closed: both banks reached
    i, j = k, k
    while i > 0 and zc[i - 1] < level:
        i -= 1
    while j < len(zc) - 1 and zc[j + 1] < level:
        j += 1
    return offs[i], offs[j], i > 0 and j < len(zc) - 1


def across(s, above, margin):
    c, n, offs, zc, k = cross(s)
    a, b, closed = span(offs, zc, k, zc[k] + above)
    ends = [c + (a - margin) * n, c + (b + margin) * n]
    return [[round(p[0], 1), round(p[1], 1)] for p in ends], zc[k], b - a, closed


stations = np.arange(1000, 3001, 50)
confined = {}
print("station  thalweg  incision(60 m)  width at +10 m")
for s in stations:
    c, n, offs, zc, k = cross(s)
    side = np.nanmean(zc[np.abs(np.abs(offs - offs[k]) - 60) <= 5])
    a, b, closed = span(offs, zc, k, zc[k] + 10)
    confined[s] = (closed, b - a)
    print("%7.0f %8.1f %10.1f %12s" % (s, zc[k], side - zc[k], "%.0f m" % (b - a) if closed else "open"))
apex = min(s for s in stations if all(not confined[t][0] for t in stations if t >= s))
dam3 = max(s for s in stations if s < apex and confined[s][0])
dam1 = min((s for s in stations if 1200 <= s <= 1700 and confined[s][0]), key=lambda s: confined[s][1])
mid = 0.5 * (dam1 + dam3)
dam2 = min((s for s in stations if abs(s - mid) <= 100 and confined[s][0]), key=lambda s: confined[s][1])
print("\nfan apex %.0f m; Dam1 %.0f, Dam2 %.0f (midway %.0f), Dam3 %.0f m of path" % (apex, dam1, dam2, mid, dam3))
print("inflow", across(1000, 4, 2))
for name, s in (("Dam1", dam1), ("Dam2", dam2), ("Dam3", dam3)):
    print(name, across(s, 10, 0))
for name, s in (("S1", dam1 + 30), ("S2", dam2 + 30), ("S3", dam3 + 30)):
    print(name, across(s, 10, 10))
(p0, _, n0), (p1, _, n1) = frame(2500), frame(2900)
print("Village", [[round(v, 1) for v in p] for p in (p0 - 120 * n0, p1 - 120 * n1, p1 + 120 * n1, p0 + 120 * n0)])

# Rickenmann (1999): L = 1.9 V^0.16 He^0.83 from the inflow's thalweg point, the toe where the straight distance
# reaches it (and at 0.75 and 1.25 of it, the band).
c, n, offs, zc, k = cross(1000)
start, z_in = c + offs[k] * n, zc[k]
for f in (0.75, 1.0, 1.25):
    toe = None
    for s in np.arange(1500, S[-1], 5.0):
        p = frame(s)[0]
        z = ground(*p)
        if np.isnan(z):
            break
        L = np.hypot(*(p - start))
        if L >= f * 1.9 * 30000 ** 0.16 * (z_in - z) ** 0.83:
            toe = (s, L, z, z_in - z)
            break
    print("Rickenmann x %.2f:" % f, "toe at %.0f m of path, L %.0f m, %.1f m, He %.0f m" % toe if toe else "beyond the DEM")
