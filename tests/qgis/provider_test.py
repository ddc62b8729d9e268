#!/usr/bin/python3
"""The QGIS provider (qgis/runout_provider, docs/qgis.md) run headless by `qgis_process` on the laboratory flume
at draft fidelity: ctest `qgis_provider`.

    /usr/bin/python3 tests/qgis/provider_test.py --runout build/runout --work build/qgis-provider

1. A check-dam layer without crest_height is refused naming the dam, the field and the accepted range.
2. runout:runscene with the local binary, layout C6 (FD_P1 + CD_P2) drawn as GeoJSON layers: the scene written
   holds the flume's release, structures, zones and sections as flume.json has them; the run completed; every
   hazard raster opens in GDAL with nodata, the DEM's CRS and its .qml; hazard.gpkg has the polygons with their
   styles in layer_styles and the structures as built; progress reached the log. The result is rendered with
   qgis/render_result.py (styles as loaded: the .qml's pseudocolour, layer_styles' categories).
3. The same through `runout serve` with a token (a wrong token: 401, named): same files, .qml included, same
   particle count as the local run.
4. runout:comparelayouts on a two-layout sweep (C0, C6) of the scene written in 2: one row per layout, the
   baseline first, the decision metrics' columns.
Exits 77 (ctest: skipped) when qgis_process is not installed.
"""
import argparse
import csv
import json
import os
import pathlib
import shutil
import sqlite3
import subprocess
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[2]
FLUME = ROOT / "scenarios/flume"
sys.path.insert(0, str(ROOT / "tests/qgis"))
import flume_layers  # noqa: E402

RASTERS = ("max_depth", "max_speed", "deposit_depth", "max_hv", "arrival_time", "max_pressure", "intensity")
FAILURES = []


def check(ok, what):
    print(("ok    " if ok else "FAIL  ") + what, flush=True)
    if not ok:
        FAILURES.append(what)


def qt_env(work):
    """Qt offscreen, with a runtime directory of its own (Qt wants one, mode 0700)."""
    runtime = work / "xdg-runtime"
    runtime.mkdir(mode=0o700, parents=True, exist_ok=True)
    # GDAL_PAM_ENABLED=NO: nothing (.aux.xml statistics) written beside the shipped flume DEM
    return dict(os.environ, QT_QPA_PLATFORM="offscreen", XDG_RUNTIME_DIR=str(runtime), GDAL_PAM_ENABLED="NO")


def qgis_process_binary():
    # Debian's /usr/bin/qgis_process wrapper passes /etc/default/qgis's --noversioncheck, which qgis_process.bin
    # refuses ("Command --noversioncheck not known!"): call the binary itself.
    exe = shutil.which("qgis_process")
    if exe is None:
        return None
    real = exe + ".bin"
    return real if os.access(real, os.X_OK) else exe


class Qgis:
    def __init__(self, exe, work):
        self.exe = exe
        profile = work / "qgis-profile"  # a profile of its own: the user's QGIS settings are left alone
        profile.mkdir(parents=True, exist_ok=True)
        self.env = dict(qt_env(work), QGIS_PLUGINPATH=str(ROOT / "qgis"), QGIS_CUSTOM_CONFIG_PATH=str(profile),
                        PYTHONDONTWRITEBYTECODE="1")

    def call(self, *args):
        return subprocess.run([self.exe, *args], env=self.env, capture_output=True, text=True, timeout=600)

    def run(self, alg, params):
        """(exit code, results or None, stdout + stderr). The text output, not --json: only it shows the
        progress bar ("0...10...20")."""
        done = self.call("run", alg, *[f"--{k}={v}" for k, v in params.items()])
        text = done.stdout + done.stderr
        if done.returncode != 0 or "\nResults\n" not in done.stdout:
            return done.returncode, None, text
        block = done.stdout.split("\nResults\n", 1)[1]
        results = dict(line.split(":\t", 1) for line in block.splitlines() if ":\t" in line)
        return done.returncode, results, text


def run_scene_params(layers, out, runout):
    return {"DEM": FLUME / "flume_dem.asc", "RELEASE": layers["release"], "CHECK_DAMS": layers["check_dams"],
            "STRUCTURE_AREAS": layers["structure_areas"], "ZONES": layers["zones"], "SECTIONS": layers["sections"],
            "CORRIDOR": layers["corridor"], "NAME": "flume-qgis", "DP": 0.025, "DURATION": 3.5, "FIDELITY": 0,
            # flume.json's friction-HBP material, c0 and outputs
            "DENSITY": 2000, "FRICTION_ANGLE": 28, "COHESION": 0, "VISCOSITY": 1.0, "FLOW_INDEX": 1.05,
            "REGULARISATION": 100, "SPEED_OF_SOUND": 40, "SERIES_INTERVAL": 0.02, "INUNDATION_THRESHOLD": 0.005,
            "THREADS": 1, "RUNOUT": runout, "OUTPUT": out}


def check_refusal(q, layers, work, runout):
    bad = work / "bad_dams.geojson"
    doc = json.loads(pathlib.Path(layers["check_dams"]).read_text())
    for f in doc["features"]:
        del f["properties"]["crest_height"]
    bad.write_text(json.dumps(doc))
    params = run_scene_params({**layers, "check_dams": str(bad)}, work / "refused", runout)
    rc, _, text = q.run("runout:runscene", params)
    check(rc != 0, "a check dam without crest_height is refused")
    check("structures[0].crest_height" in text and "(0, 200]" in text and "check dam 'CD_P2'" in text
          and "bad_dams" in text, "the refusal names the dam, its layer, the field and the accepted range")


def check_scene(scene_path):
    written = json.loads(pathlib.Path(scene_path).read_text())
    flume = json.loads((FLUME / "flume.json").read_text())
    by_name = lambda items: sorted(items, key=lambda s: s["name"])  # noqa: E731
    check(written["release"] == flume["release"], "the scene's release is flume.json's (polygon, depth)")
    check(by_name(written["structures"]) == by_name([s for s in flume["structures"] if s["name"] in ("FD_P1", "CD_P2")]),
          "the scene's structures are flume.json's FD_P1 and CD_P2, attributes from the layers' fields")
    check(written["protected_zones"] == flume["protected_zones"] and written["monitors"] == flume["monitors"]
          and written["terrain"]["corridor"] == flume["terrain"]["corridor"],
          "the zones, sections and corridor are flume.json's")


def check_rasters(out, dem_wkt, expect_qml=True):
    from osgeo import gdal, osr
    dem_srs = osr.SpatialReference(wkt=dem_wkt)
    for name in RASTERS:
        tif = out / "rasters" / f"{name}.tif"
        ds = gdal.Open(str(tif)) if tif.exists() else None
        check(ds is not None, f"{name}.tif opens in GDAL")
        if ds is None:
            continue
        band = ds.GetRasterBand(1)
        check(band.GetNoDataValue() is not None, f"{name}.tif has nodata")
        check(osr.SpatialReference(wkt=ds.GetProjection()).IsSame(dem_srs) == 1, f"{name}.tif is in the DEM's CRS")
        if expect_qml:
            check((out / "rasters" / f"{name}.qml").exists(), f"{name}.qml lies beside it")
    gdal.Open(str(out / "rasters" / "max_depth.tif"))
    ds = gdal.Open(str(out / "rasters" / "max_depth.tif"))
    stats = ds.GetRasterBand(1).ComputeRasterMinMax(False)
    check(stats[1] > 0.005, f"max_depth.tif has flow deeper than the threshold (max {stats[1]:.3f} m)")


def check_hazard(out):
    gpkg = out / "rasters" / "hazard.gpkg"
    with sqlite3.connect(f"file:{gpkg}?mode=ro", uri=True) as db:
        layers = {r[0] for r in db.execute("SELECT table_name FROM gpkg_contents")}
        styled = {r[0] for r in db.execute("SELECT f_table_name FROM layer_styles WHERE useAsDefault = 1")}
        dams = [r[0] for r in db.execute("SELECT name FROM check_dams")] if "check_dams" in layers else []
        areas = [r[0] for r in db.execute("SELECT name FROM structure_areas")] if "structure_areas" in layers else []
        polygons = db.execute("SELECT COUNT(*) FROM inundated").fetchone()[0] if "inundated" in layers else 0
    check({"inundated", "intensity"} <= styled, f"hazard.gpkg's inundated and intensity have default styles ({sorted(styled)})")
    built = {"check_dams", "structure_areas"} & layers
    check(built <= styled, f"hazard.gpkg's built structures {sorted(built)} have default styles ({sorted(styled)})")
    check(polygons > 0, f"hazard.gpkg's inundated layer has polygons ({polygons})")
    check(dams == ["CD_P2"] and areas == ["FD_P1"], f"hazard.gpkg has the structures as built ({dams}, {areas})")


def metrics(out):
    return json.loads((out / "metrics.json").read_text())


def check_local(q, layers, work, runout, dem_wkt):
    out = work / "local"
    t0 = time.monotonic()
    rc, res, text = q.run("runout:runscene", run_scene_params(layers, out, runout))
    print(f"      runout:runscene (local) {time.monotonic() - t0:.0f} s")
    check(rc == 0 and res is not None, "runout:runscene with the local binary succeeds" + ("" if rc == 0 else ": " + text[-2000:]))
    if res is None:
        return None
    check(res["STATUS"] == "completed" and metrics(out)["status"] == "completed", "metrics.json: completed")
    check(res["MAX_DEPTH"] == str(out / "rasters" / "max_depth.tif")
          and res["HAZARD_INTENSITY"].endswith("hazard.gpkg|layername=intensity"),
          "the results name the rasters and hazard.gpkg's layers")
    check("...50" in text and "...90" in text, "runout's progress reached QGIS's progress bar")
    check_scene(res["SCENE"])
    check_rasters(out, dem_wkt)
    check_hazard(out)
    return out


def check_render(out, layers, work):
    png = work / "flume-provider.png"
    env = qt_env(work)
    done = subprocess.run(["/usr/bin/python3", str(ROOT / "qgis/render_result.py"), str(out), "--dem",
                           str(FLUME / "flume_dem.asc"), "--zones", str(layers["zones"]), "--out", str(png),
                           "--title", "Runout QGIS provider: the flume, layout C6 (FD_P1 + CD_P2), draft"],
                          env=env, capture_output=True, text=True, timeout=300)
    check(done.returncode == 0, "qgis/render_result.py renders the result" + ("" if done.returncode == 0 else ": " + done.stderr[-1000:]))
    if done.returncode != 0:
        return
    summary = json.loads(done.stdout.strip().splitlines()[-1])
    check(summary["max_depth"]["renderer"] == "singlebandpseudocolor", "max_depth loads with its .qml's colour ramp")
    check(summary["inundated"]["renderer"] == "categorizedSymbol", "inundated loads with layer_styles' categories")
    check(png.stat().st_size > 10000, f"the picture has content ({png.stat().st_size} bytes)")


def start_service(runout, work):
    (work / "token").write_text("qgis-test-token\n")
    log = open(work / "serve.log", "w")
    proc = subprocess.Popen([runout, "serve", "--port", "0", "--db", str(work / "service.db"), "--runs",
                             str(work / "service-runs"), "--scene-dir", str(FLUME), "--token-file", str(work / "token"),
                             "--workers", "1", "--threads-per-job", "1"], stdout=subprocess.PIPE, stderr=log, text=True)
    line = proc.stdout.readline()
    if "listening on " not in line:
        proc.kill()
        raise SystemExit(f"runout serve did not start: {line} (log: {work / 'serve.log'})")
    return proc, line.split("listening on ")[1].split()[0]


def check_service(q, layers, work, runout, dem_wkt, local):
    proc, url = start_service(runout, work)
    try:
        wrong = work / "wrong-token"
        wrong.write_text("not-the-token\n")
        params = run_scene_params(layers, work / "service-refused", runout)
        # 0.5 s of flow: this checks the transport (submit, follow, fetch), the local run the physics
        params.update(SERVICE_URL=url, TOKEN_FILE=wrong, SERVICE_DEM="flume_dem.asc", DURATION=0.5)
        rc, _, text = q.run("runout:runscene", params)
        check(rc != 0 and "401" in text, "a wrong token is refused with the service's 401")
        out = work / "service"
        params.update(TOKEN_FILE=work / "token", OUTPUT=out)
        t0 = time.monotonic()
        rc, res, text = q.run("runout:runscene", params)
        print(f"      runout:runscene (service) {time.monotonic() - t0:.0f} s")
        check(rc == 0 and res is not None, "runout:runscene through the service succeeds" + ("" if rc == 0 else ": " + text[-2000:]))
        if res is None:
            return
        check(metrics(out)["status"] == "completed", "the service's metrics.json: completed")
        check_rasters(out, dem_wkt)
        check_hazard(out)
        if local is not None:
            same = [k for k in ("fluid_initial", "boundary") if metrics(out)["particles"][k] == metrics(local)["particles"][k]]
            check(len(same) == 2, "the service built the local run's particles (flow and walls described)")
    finally:
        proc.terminate()
        proc.wait(timeout=60)


def check_compare(q, work, runout, local):
    # The scene the provider wrote, cut to 2 s (the front passes the outlet by 1.5 s): two layouts at once
    base = json.loads((local / "scene.json").read_text())
    base["duration"] = 2.0
    (work / "base.json").write_text(json.dumps(base))
    sweep = work / "sweep.json"
    sweep.write_text(json.dumps({"name": "flume-qgis-sweep", "base": "base.json", "fidelity": "draft",
                                 "variants": [{"name": "C0", "structures": []},
                                              {"name": "C6", "structures": ["FD_P1", "CD_P2"]}]}))
    table = work / "compare.csv"
    t0 = time.monotonic()
    rc, res, text = q.run("runout:comparelayouts", {"SWEEP": sweep, "JOBS": 2, "THREADS": 1, "RUNOUT": runout,
                                                    "RUNS": work / "sweep-runs", "OUTPUT": table})
    print(f"      runout:comparelayouts {time.monotonic() - t0:.0f} s")
    check(rc == 0, "runout:comparelayouts runs the sweep and compares it" + ("" if rc == 0 else ": " + text[-2000:]))
    if rc != 0:
        return
    check("...50" in text and "...100" in text, "the sweep's progress reached QGIS's progress bar")
    with open(table, newline="") as f:
        rows = list(csv.DictReader(f))
    check([r["layout"] for r in rows] == ["C0", "C6"], f"one row per layout, the baseline first ({[r['layout'] for r in rows]})")
    cols = set(rows[0]) if rows else set()
    outlet = "monitors.section.Outlet.peak_discharge_m3_s"
    fd = "terrain.structures.deposition_area.FD_P1.retained_volume_m3"
    expected = {"layout", "run_id", "baseline", outlet, outlet + "_pct", fd, "terrain.inundation.inundated_area_m2",
                "terrain.protected_zones.Village.arrival_time_s", "terrain.inundation.runout_m"}
    check(expected <= cols, f"the decision metrics' columns ({sorted(expected - cols)} missing)")
    if len(rows) == 2 and expected <= cols:
        check(rows[0]["baseline"] == "1" and rows[1]["baseline"] == "0" and float(rows[0][outlet + "_pct"]) == 0,
              "the baseline row is marked and at 0 %")
        check(rows[0][fd] == "" and float(rows[1][fd]) >= 0, "FD_P1's retained volume: none in C0, a value in C6")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runout", required=True)
    ap.add_argument("--work", required=True, type=pathlib.Path)
    args = ap.parse_args()
    exe = qgis_process_binary()
    if exe is None:
        print("SKIPPED: qgis_process is not installed (Debian's qgis package; scripts/install-deps.sh installs it)")
        return 77
    shutil.rmtree(args.work, ignore_errors=True)
    args.work.mkdir(parents=True)
    t0 = time.monotonic()
    q = Qgis(exe, args.work)
    enabled = q.call("plugins", "enable", "runout_provider")
    listed = q.call("list").stdout
    check(enabled.returncode == 0 and "runout:runscene" in listed and "runout:comparelayouts" in listed,
          "qgis_process loads the provider's two algorithms")
    layers = {k: str(v) for k, v in flume_layers.write(args.work / "layers", ["FD_P1", "CD_P2"]).items()}
    from osgeo import gdal
    dem_wkt = gdal.Open(str(FLUME / "flume_dem.asc")).GetProjection()
    check_refusal(q, layers, args.work, args.runout)
    local = check_local(q, layers, args.work, args.runout, dem_wkt)
    if local is not None:
        check_render(local, layers, args.work)
    check_service(q, layers, args.work, args.runout, dem_wkt, local)
    if local is not None:
        check_compare(q, args.work, args.runout, local)
    print(f"{len(FAILURES)} failed; {time.monotonic() - t0:.0f} s")
    return 1 if FAILURES else 0


if __name__ == "__main__":
    sys.exit(main())
