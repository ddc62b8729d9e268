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
5. The same sweep through the service of 3: the same table, and the decision metrics equal bit for bit to the
   local runs' (one thread a run on both sides); refusals naming SWEEP / SERVICE_DEM, BASELINE, an ensemble.
Before QGIS (and without it): the table conversions of an ensemble summary and of a service comparison, in
plain Python (qgis/runout_provider/tables.py).
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
                             # two workers: the sweep's two layouts at once, as the local sweep's JOBS 2; one
                             # thread each, as locally, so that the runs repeat bit for bit (check_compare_service)
                             "--workers", "2", "--threads-per-job", "1"], stdout=subprocess.PIPE, stderr=log, text=True)
    line = proc.stdout.readline()
    if "listening on " not in line:
        proc.kill()
        raise SystemExit(f"runout serve did not start: {line} (log: {work / 'serve.log'})")
    return proc, line.split("listening on ")[1].split()[0]


def check_service(q, layers, work, runout, dem_wkt, local, url):
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


SWEEP_NAME = "flume-qgis-sweep"


def write_sweep(work, local):
    """The scene the provider wrote, cut to 2 s (the front passes the outlet by 1.5 s), as the base of a sweep
    of C0 and C6."""
    base = json.loads((local / "scene.json").read_text())
    base["duration"] = 2.0
    (work / "base.json").write_text(json.dumps(base))
    sweep = work / "sweep.json"
    sweep.write_text(json.dumps({"name": SWEEP_NAME, "base": "base.json", "fidelity": "draft",
                                 "variants": [{"name": "C0", "structures": []},
                                              {"name": "C6", "structures": ["FD_P1", "CD_P2"]}]}))
    return sweep


def read_table(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def check_compare(q, work, runout, sweep):
    """The local sweep, two layouts at once; returns the table's rows (None when it failed)."""
    table = work / "compare.csv"
    t0 = time.monotonic()
    rc, res, text = q.run("runout:comparelayouts", {"SWEEP": sweep, "JOBS": 2, "THREADS": 1, "RUNOUT": runout,
                                                    "RUNS": work / "sweep-runs", "OUTPUT": table})
    print(f"      runout:comparelayouts {time.monotonic() - t0:.0f} s")
    check(rc == 0, "runout:comparelayouts runs the sweep and compares it" + ("" if rc == 0 else ": " + text[-2000:]))
    if rc != 0:
        return None
    check("...50" in text and "...100" in text, "the sweep's progress reached QGIS's progress bar")
    rows = read_table(table)
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
    return rows


def decision_values_cli(doc):
    """{(layout, metric): value} of `runout compare --format json`'s decision metrics."""
    out = {}
    for r in doc["rows"]:
        if r["decision"]:
            out[(doc["baseline"], r["metric"])] = r["baseline"]
            out.update({(label, r["metric"]): r["values"][k] for k, label in enumerate(doc["runs"])})
    return out


def decision_values_service(doc):
    """{(layout, metric): value} of the service's GET /compare decision metrics."""
    out = {}
    for r in doc["metrics"]:
        if r["decision"]:
            out[(doc["baseline"]["label"], r["metric"])] = r["baseline"]
            out.update({(j["label"], r["metric"]): r["values"][k] for k, j in enumerate(doc["jobs"])})
    return out


def check_compare_service(q, work, runout, sweep, url, local_rows):
    """The same sweep through the service. Its runs are new ones (the base's DEM is named `flume_dem.asc`, not the
    local path, so the manifests differ), at one thread each as the local runs: a run on one thread repeats bit
    for bit on one machine (docs/validation.md, "Not the same run on every machine"; the MPI sweep's stored
    records are checked so, docs/cluster.md), so the values must be equal, not close."""
    runs, table = work / "service-sweep", work / "compare-service.csv"
    params = {"SWEEP": sweep, "SERVICE_URL": url, "TOKEN_FILE": work / "token", "RUNS": runs, "OUTPUT": table}
    t0 = time.monotonic()
    rc, _, text = q.run("runout:comparelayouts", params)
    print(f"      runout:comparelayouts (service) {time.monotonic() - t0:.0f} s")
    check(rc == 0, "runout:comparelayouts through the service" + ("" if rc == 0 else ": " + text[-2000:]))
    if rc != 0:
        return
    check("...100" in text, "the service sweep's progress reached QGIS's progress bar")
    rows = read_table(table)
    check([r["layout"] for r in rows] == ["C0", "C6"], f"the service's table: C0 then C6 ({[r['layout'] for r in rows]})")
    if local_rows is not None and rows:
        same_cols = set(rows[0]) == set(local_rows[0])
        check(same_cols, f"the service's table has the local one's columns ({sorted(set(rows[0]) ^ set(local_rows[0]))} differ)")
        diff = [(r["layout"], k) for r, lr in zip(rows, local_rows) for k in lr if k != "run_id" and r.get(k) != lr[k]]
        check(same_cols and not diff, f"the service's table has the local one's values ({diff[:5]} differ)")
    local_doc = json.loads(subprocess.run([runout, "compare", "--sweep", SWEEP_NAME, "--format", "json", "--db",
                                           str(work / "sweep-runs" / "runout.db")], capture_output=True, text=True).stdout)
    saved = sorted(runs.glob("compare-sweep-*.json"))
    check(len(saved) == 1, f"the service's comparison is kept in RUNS ({[p.name for p in saved]})")
    if saved:
        local, served = decision_values_cli(local_doc), decision_values_service(json.loads(saved[0].read_text()))
        differ = sorted(k for k in local.keys() | served.keys() if local.get(k, "absent") != served.get(k, "absent"))
        check(len(local) >= 10 and not differ, f"the service's decision metrics equal the local runs' bit for bit "
              f"({len(local)} values; differ: {differ[:5]})")
    check_service_refusals(q, work, sweep, url)


def check_service_refusals(q, work, sweep, url):
    """What comparelayouts refuses with a service, each naming the parameter (no run: seconds each)."""
    base = {"SERVICE_URL": url, "TOKEN_FILE": work / "token", "RUNS": work / "service-refused-sweep",
            "OUTPUT": work / "refused.csv"}
    rc, _, text = q.run("runout:comparelayouts", {**base, "SWEEP": sweep, "SERVICE_DEM": "../flume_dem.asc"})
    check(rc != 0 and "SWEEP: the service refused" in text and "(422)" in text and "terrain.dem" in text
          and "SERVICE_DEM" in text, "a DEM outside the service's scene dir: its 422, naming SWEEP, terrain.dem and SERVICE_DEM")
    rc, _, text = q.run("runout:comparelayouts", {**base, "SWEEP_NAME": SWEEP_NAME, "BASELINE": "C9"})
    check(rc != 0 and "BASELINE: 'C9' is not a layout of sweep" in text and "C0, C6" in text,
          "SWEEP_NAME finds the service's sweep; an unknown BASELINE is refused with its layouts")
    ensemble = work / "ensemble.json"
    ensemble.write_text(json.dumps({**json.loads(sweep.read_text()), "name": "flume-qgis-ensemble", "ensemble": {
        "parameters": [{"pointer": "/materials/0/friction_angle", "values": [27, 29]}]}}))
    rc, _, text = q.run("runout:comparelayouts", {**base, "SWEEP": ensemble})
    check(rc != 0 and "SWEEP:" in text and "ensemble sweep; the service takes no ensemble" in text,
          "an ensemble sweep with a service is refused, naming SWEEP")


# Pure Python (no QGIS): the provider's conversions of comparisons into tables (qgis/runout_provider/tables.py).
Q = "monitors.section.Outlet.peak_discharge_m3_s"
ARR = "terrain.protected_zones.Village.arrival_time_s"
FD = "terrain.structures.deposition_area.FD_P1.retained_volume_m3"


def check_ensemble_table(tables):
    """An ensemble summary (ensemble_summary.hpp's JSON) written by hand, and the rows it must give."""
    q = lambda a, b, c, n: {"p10": a, "p50": b, "p90": c, "count": n, "never": 0}  # noqa: E731
    summary = {"sweep": "ens", "layouts": ["G0", "G1"], "members": 4, "incomplete": 1, "ranking_metric": Q,
               "ranked_members": 4, "layouts_detail": {
                   "G0": {"first_share": 0.25, "metrics": {
                       Q: q(1.0, 1.5, 2.0, 4), ARR: {"p10": None, "p50": None, "p90": None, "count": 0, "never": 4}}},
                   "G1": {"first_share": 0.75, "metrics": {
                       Q: q(0.5, 0.75, 1.25, 4), ARR: {"p10": 3.0, "p50": 3.5, "p90": 4.0, "count": 3, "never": 1},
                       FD: q(10.0, 12.0, 14.0, 4)}}}}
    check(tables.is_ensemble(summary) and not tables.is_ensemble({"rows": []}), "an ensemble summary is told by layouts_detail")
    names, rows = tables.ensemble_table_of(summary)
    expected = ["layout", "first_share"] + [f"{m}_{s}" for m in (Q, ARR, FD) for s in ("p10", "p50", "p90", "never")]
    check(names == expected, "the ensemble table's fields: layout, first_share, p10/p50/p90/never per metric"
          + ("" if names == expected else f" ({names})"))
    expected = [["G0", 0.25, 1.0, 1.5, 2.0, 0, None, None, None, 4, None, None, None, None],
                ["G1", 0.75, 0.5, 0.75, 1.25, 0, 3.0, 3.5, 4.0, 1, 10.0, 12.0, 14.0, 0]]
    check(rows == expected, "one row per layout, baseline first; never counted; empty where no member has a value or "
          "the layout no such metric" + ("" if rows == expected else f" ({rows})"))
    check([r[0] for r in tables.ensemble_table_of(summary, "G1")[1]] == ["G1", "G0"], "a BASELINE layout comes first")
    try:
        tables.ensemble_table_of(summary, "G9")
        check(False, "an unknown baseline of an ensemble is refused")
    except ValueError as e:
        check("'G9'" in str(e) and "G0, G1" in str(e), f"an unknown baseline of an ensemble is refused with the layouts ({e})")
    check([tables.field_kind(n) for n in ("layout", "first_share", Q + "_p50", Q + "_never")] == ["text", "double", "double", "int"],
          "the ensemble table's field types: text, double, double, integer count")


def check_service_table(tables):
    """A service GET /compare document written by hand (layouts in submission order, C6 before C1; one metric
    that is not a decision metric), and the table `runout compare --format json` of the same runs gives."""
    doc = {"baseline": {"job": 1, "run_id": 11, "label": "C0"}, "sweep": None, "outlet": "Outlet", "ranking": None,
           "jobs": [{"job": 3, "run_id": 13, "label": "C6"}, {"job": 2, "run_id": 12, "label": "C1"}],
           "metrics": [{"metric": Q, "label": "Outlet Q_m [m³/s]", "decision": True, "better": "lower", "baseline": 2.0,
                        "baseline_never": False, "values": [1.0, 1.5], "never": [False, False],
                        "difference": [-1.0, -0.5], "percent": [-50.0, -25.0]},
                       {"metric": ARR, "label": "Village arrival [s]", "decision": True, "better": "higher",
                        "baseline": 3.0, "baseline_never": False, "values": [None, 3.5], "never": [True, False],
                        "difference": [None, 0.5], "percent": [None, 50.0 / 3]},
                       {"metric": "particles.fluid_initial", "label": "particles.fluid_initial", "decision": False,
                        "better": None, "baseline": 100, "baseline_never": False, "values": [100, 100],
                        "never": [False, False], "difference": [0, 0], "percent": [0.0, 0.0]}]}
    names, rows = tables.table_of(tables.cli_compare_of_service(doc, False))
    expected = ["layout", "run_id", "baseline", Q, Q + "_pct", ARR, ARR + "_pct", ARR + "_never"]
    check(names == expected, "the service's comparison gives the CLI's fields, decision metrics only"
          + ("" if names == expected else f" ({names})"))
    expected = [["C0", 11, 1, 2.0, 0.0, 3.0, 0.0, 0], ["C1", 12, 0, 1.5, -25.0, 3.5, 50.0 / 3, 0],
                ["C6", 13, 0, 1.0, -50.0, None, None, 1]]
    check(rows == expected, "the service's layouts: baseline first, the rest by name, values and never flags with "
          "them" + ("" if rows == expected else f" ({rows})"))
    names, _ = tables.table_of(tables.cli_compare_of_service(doc, True))
    check("particles.fluid_initial" in names, "ALL keeps the service's other metrics")


def check_tables():
    sys.path.insert(0, str(ROOT / "qgis"))
    from runout_provider import tables  # no QGIS import: the package's __init__ imports nothing
    check_ensemble_table(tables)
    check_service_table(tables)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runout", required=True)
    ap.add_argument("--work", required=True, type=pathlib.Path)
    args = ap.parse_args()
    check_tables()  # plain Python: checked with or without QGIS
    exe = qgis_process_binary()
    if exe is None:
        print("SKIPPED: qgis_process is not installed (Debian's qgis package; scripts/install-deps.sh installs it)")
        return 1 if FAILURES else 77
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
    proc, url = start_service(args.runout, args.work)
    try:
        check_service(q, layers, args.work, args.runout, dem_wkt, local, url)
        if local is not None:
            sweep = write_sweep(args.work, local)
            local_rows = check_compare(q, args.work, args.runout, sweep)
            check_compare_service(q, args.work, args.runout, sweep, url, local_rows)
    finally:
        proc.terminate()
        proc.wait(timeout=60)
    print(f"{len(FAILURES)} failed; {time.monotonic() - t0:.0f} s")
    return 1 if FAILURES else 0


if __name__ == "__main__":
    sys.exit(main())
