#!/usr/bin/env python3
"""Writes the laboratory flume's release, structures, zones, sections and corridor (scenarios/flume/flume.json)
as GeoJSON layers with their attributes as fields, the inputs a QGIS user would draw for runout:runscene.

    tests/qgis/flume_layers.py OUT_DIR [--structures FD_P1,CD_P2]

Layers (EPSG:32632, the flume DEM's CRS): release (depth), check_dams (name, crest_height, thickness),
structure_areas (type, name and the type's fields), zones (name), sections (name), corridor. Only the named
candidate structures are written (default: C6's, FD_P1 and CD_P2). Standard library only.
"""
import argparse
import json
import pathlib

ROOT = pathlib.Path(__file__).resolve().parents[2]
CRS = {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::32632"}}
AREA_KEYS = ("elevation", "gradient", "depth", "wall_height", "wall_thickness")


def feature(props, kind, points):
    coords = [list(points) + [points[0]]] if kind == "Polygon" else list(points)
    return {"type": "Feature", "properties": props, "geometry": {"type": kind, "coordinates": coords}}


def layers(scene, chosen):
    structures = [s for s in scene["structures"] if s["name"] in chosen]
    return {
        "release": [feature({"depth": scene["release"]["depth"]}, "Polygon", scene["release"]["polygon"])],
        "check_dams": [feature({"name": s["name"], "crest_height": s["crest_height"], "thickness": s["thickness"]},
                               "LineString", s["axis"]) for s in structures if s["type"] == "check_dam"],
        "structure_areas": [feature({"type": s["type"], "name": s["name"], **{k: s.get(k) for k in AREA_KEYS}},
                                    "Polygon", s["polygon"]) for s in structures if s["type"] != "check_dam"],
        "zones": [feature({"name": z["name"]}, "Polygon", z["polygon"]) for z in scene["protected_zones"]],
        "sections": [feature({"name": m["name"]}, "LineString", m["line"]) for m in scene["monitors"]
                     if m["type"] == "section"],
        "corridor": [feature({}, "Polygon", scene["terrain"]["corridor"]["polygon"])],
    }


def write(out, chosen):
    scene = json.loads((ROOT / "scenarios/flume/flume.json").read_text())
    unknown = set(chosen) - {s["name"] for s in scene["structures"]}
    if unknown:
        raise SystemExit(f"--structures: {sorted(unknown)} are not flume candidates")
    out.mkdir(parents=True, exist_ok=True)
    paths = {}
    for name, features in layers(scene, chosen).items():
        paths[name] = out / f"{name}.geojson"
        paths[name].write_text(json.dumps({"type": "FeatureCollection", "name": name, "crs": CRS,
                                           "features": features}))
    return paths


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=pathlib.Path)
    ap.add_argument("--structures", default="FD_P1,CD_P2")
    args = ap.parse_args()
    for p in write(args.out, [s for s in args.structures.split(",") if s]).values():
        print(p)


if __name__ == "__main__":
    main()
