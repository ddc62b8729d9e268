#!/usr/bin/env python3
"""Writes scenarios/catchment/layouts.gpkg from the coordinates of scenarios/catchment/jacksboro_g.json, and
scenarios/catchment/jacksboro_g_gpkg.json, the same scene reading its release, check-dam axes, protected zone
and sections from that GeoPackage (docs/scene-format.md, "Geometry from vector files").

Layers (EPSG:32616, one feature per object, a text field "name"): release (Polygon), dams (LineString),
zones (Polygon), sections (LineString). Needs python3 and ogr2ogr (gdal-bin). OGR_CURRENT_DATE is fixed so the
same coordinates give the same file (its SHA-256 enters the run manifests).

    scripts/make_catchment_layouts.py [--scene scenarios/catchment/jacksboro_g.json]
"""
import argparse
import json
import os
import pathlib
import subprocess
import tempfile

CRS = "EPSG:32616"


def feature(name, kind, points):
    if kind == "Polygon":
        coords = [list(map(list, points)) + [list(points[0])]]
    else:
        coords = [list(p) for p in points]
    return {"type": "Feature", "properties": {"name": name}, "geometry": {"type": kind, "coordinates": coords}}


def layers_of(scene):
    layers = {
        "release": [feature("release", "Polygon", scene["release"]["polygon"])],
        "dams": [feature(s["name"], "LineString", s["axis"]) for s in scene["structures"] if s["type"] == "check_dam"],
        "zones": [feature(z["name"], "Polygon", z["polygon"]) for z in scene.get("protected_zones", [])],
        "sections": [feature(m["name"], "LineString", m["line"]) for m in scene.get("monitors", [])
                     if m.get("type") == "section"],
    }
    if len(layers["dams"]) != len(scene["structures"]):
        raise SystemExit("only check dams are written to the GeoPackage; the scene has other structures")
    return layers


def write_gpkg(layers, out):
    if out.exists():
        out.unlink()
    env = dict(os.environ, OGR_CURRENT_DATE="2026-12-02T00:00:00Z")
    with tempfile.TemporaryDirectory(prefix="gis-layouts-") as tmp:
        for name, features in layers.items():
            src = pathlib.Path(tmp) / f"{name}.geojson"
            src.write_text(json.dumps({"type": "FeatureCollection", "features": features}))
            cmd = ["ogr2ogr", "-f", "GPKG", "-a_srs", CRS, "-nln", name, str(out), str(src)]
            if out.exists():
                cmd.insert(1, "-update")
            subprocess.run(cmd, check=True, env=env)


def gpkg_scene(scene, gpkg_name):
    def ref(layer, name):
        return {"layer": gpkg_name, "name": layer, "where": f"name = '{name}'"}

    s = json.loads(json.dumps(scene))
    s["name"] = scene["name"] + "-gpkg"
    s["description"] = ("The scene of jacksboro_g.json with its release, check-dam axes, protected zone and sections "
                        f"read from {gpkg_name} (written by scripts/make_catchment_layouts.py).")
    s["release"]["polygon"] = {"layer": gpkg_name, "name": "release"}
    for st in s["structures"]:
        st["axis"] = ref("dams", st["name"])
    for z in s.get("protected_zones", []):
        z["polygon"] = ref("zones", z["name"])
    for m in s.get("monitors", []):
        if m.get("type") == "section":
            m["line"] = ref("sections", m["name"])
    return s


def main():
    root = pathlib.Path(__file__).resolve().parent.parent
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default=str(root / "scenarios/catchment/jacksboro_g.json"))
    args = ap.parse_args()
    scene_path = pathlib.Path(args.scene)
    scene = json.loads(scene_path.read_text())
    gpkg = scene_path.parent / "layouts.gpkg"
    write_gpkg(layers_of(scene), gpkg)
    out = scene_path.parent / (scene_path.stem + "_gpkg.json")
    out.write_text(json.dumps(gpkg_scene(scene, gpkg.name), indent=2) + "\n")
    print(f"wrote {gpkg} and {out}")


if __name__ == "__main__":
    main()
