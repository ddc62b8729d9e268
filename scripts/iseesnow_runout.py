#!/usr/bin/env python3
"""Runout and affected area of ISeeSnow results by the intercomparison's own rule (ISeeSnowCfg.ini, ana3AIMEC:
runoutResType pfv, thresholdValue 1, domainWidth 1400): the farthest point, in arc length along the thalweg
path_aimec, of a cell whose peak flow velocity exceeds 1 m/s within 700 m of the path; the area is those cells'.

  /usr/bin/python3 scripts/iseesnow_runout.py PATH_SHP RASTER [RASTER ...]

Each RASTER is a peak-velocity grid GDAL opens (the peers' *_pfv.asc / *_s_max.asc, or a run's max_speed.tif).
Prints one line per raster: runout s [m], affected area [m2], and the name.
"""
import sys

import numpy as np
from osgeo import gdal, ogr

THRESHOLD, HALF_WIDTH = 1.0, 700.0


def path_points(shp):
    ds = ogr.Open(shp)  # kept while its layer and geometry are read (OGR frees them with it)
    feature = ds.GetLayer(0).GetNextFeature()
    geom = feature.GetGeometryRef()
    return np.array([geom.GetPoint_2D(k) for k in range(geom.GetPointCount())])


def project(path, x, y):
    """Arc length s of each point's nearest point on the polyline, and its distance l from it."""
    best_s = np.full(x.shape, np.nan)
    best_l = np.full(x.shape, np.inf)
    s0 = 0.0
    for a, b in zip(path[:-1], path[1:]):
        d = b - a
        length = np.hypot(*d)
        t = np.clip(((x - a[0]) * d[0] + (y - a[1]) * d[1]) / length**2, 0, 1)
        l = np.hypot(x - (a[0] + t * d[0]), y - (a[1] + t * d[1]))
        closer = l < best_l
        best_s[closer], best_l[closer] = s0 + t[closer] * length, l[closer]
        s0 += length
    return best_s, best_l


def runout(path, raster):
    ds = gdal.Open(raster)
    v = ds.GetRasterBand(1).ReadAsArray().astype(float)
    nodata = ds.GetRasterBand(1).GetNoDataValue()
    if nodata is not None:
        v[v == nodata] = 0
    gt = ds.GetGeoTransform()
    iy, ix = np.nonzero(np.nan_to_num(v) > THRESHOLD)
    x = gt[0] + (ix + 0.5) * gt[1] + (iy + 0.5) * gt[2]
    y = gt[3] + (ix + 0.5) * gt[4] + (iy + 0.5) * gt[5]
    s, l = project(path, x, y)
    inside = l <= HALF_WIDTH
    return (s[inside].max() if inside.any() else float("nan")), inside.sum() * abs(gt[1] * gt[5])


if __name__ == "__main__":
    path = path_points(sys.argv[1])
    for r in sys.argv[2:]:
        s, area = runout(path, r)
        print(f"{s:9.1f} m  {area:10.0f} m2  {r}")
