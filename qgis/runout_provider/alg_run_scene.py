"""runout:runscene: layers -> scene.json -> `runout run` (or a service job) -> hazard rasters and polygons."""
import json
import os
import sqlite3

from qgis.core import (QgsProcessing, QgsProcessingAlgorithm, QgsProcessingContext, QgsProcessingException,
                       QgsProcessingLayerPostProcessorInterface, QgsProcessingOutputFile,
                       QgsProcessingOutputRasterLayer, QgsProcessingOutputString,
                       QgsProcessingOutputVectorLayer, QgsProcessingParameterDefinition,
                       QgsProcessingParameterEnum, QgsProcessingParameterFeatureSource, QgsProcessingParameterFile,
                       QgsProcessingParameterFolderDestination, QgsProcessingParameterNumber,
                       QgsProcessingParameterRasterLayer, QgsProcessingParameterString)

from . import runner, scene
from .runner import ANY_FILE

FIDELITIES = ("draft", "standard", "fine", "screening")
HAZARD_LAYERS = ("inundated", "intensity", "check_dams", "structure_areas")
# (key, label, default, minimum, maximum): the friction-HBP material of docs/scene-format.md; runout checks the
# ranges again and names the field.
MATERIAL = (
    ("DENSITY", "Bulk density (kg/m³)", 2000.0, 1.0, 1e5),
    ("FRICTION_ANGLE", "Friction angle φ (degrees)", 28.0, 0.0, 89.0),
    ("COHESION", "Cohesion c (Pa)", 0.0, 0.0, 1e7),
    ("VISCOSITY", "Viscosity μ (Pa s)", 1.0, 0.0, 1e6),
    ("FLOW_INDEX", "Flow index n", 1.05, 0.1, 3.0),
    ("REGULARISATION", "Papanastasiou regularisation m (s)", 100.0, 0.0, 1e6),
)
MATERIAL_KEYS = {"DENSITY": "density", "FRICTION_ANGLE": "friction_angle", "COHESION": "cohesion",
                 "VISCOSITY": "viscosity", "FLOW_INDEX": "flow_index", "REGULARISATION": "regularisation"}


_POST_PROCESSORS = []


def _gpkg_layers(path):
    """The layers a GeoPackage holds (a run without structures has no check_dams or structure_areas)."""
    if not os.path.exists(path):
        return set()
    with sqlite3.connect(f"file:{path}?mode=ro", uri=True) as db:
        return {r[0] for r in db.execute("SELECT table_name FROM gpkg_contents")}


class _Style(QgsProcessingLayerPostProcessorInterface):
    """Applies the .qml runout wrote beside a raster once the layer is in the project (QGIS would also find it as
    the default style; explicit, so the style does not depend on that setting)."""

    def __init__(self, qml):
        super().__init__()
        self.qml = qml

    def postProcessLayer(self, layer, context, feedback):  # noqa: N802
        if os.path.exists(self.qml):
            layer.loadNamedStyle(self.qml)
            layer.triggerRepaint()


class RunSceneAlgorithm(QgsProcessingAlgorithm):
    def name(self):
        return "runscene"

    def displayName(self):  # noqa: N802
        return "Run scene"

    def group(self):
        return "Runout"

    def groupId(self):  # noqa: N802
        return "runout"

    def shortHelpString(self):  # noqa: N802
        return ("Writes a Runout scene from the layers (geometry in the DEM's CRS, attributes from the fields named as "
                "the scene's keys: release depth or volume; hydrograph depth and discharge, or volume and duration; "
                "check dams name, crest_height, thickness, slit_width, slit_bottom; structure areas type "
                "(deposition_area or retention_basin), name, elevation, gradient, depth, wall_height, wall_thickness, "
                "open_edges; zones and sections name), runs it with the local runout binary or submits it to a "
                "runout service, and loads the hazard rasters and hazard.gpkg's polygons with Runout's styles. "
                "See docs/qgis.md.")

    def createInstance(self):  # noqa: N802
        return RunSceneAlgorithm()

    def _advanced(self, p):
        p.setFlags(p.flags() | QgsProcessingParameterDefinition.FlagAdvanced)
        self.addParameter(p)

    def initAlgorithm(self, config=None):  # noqa: N802
        V = QgsProcessing
        self.addParameter(QgsProcessingParameterRasterLayer("DEM", "DEM (a file GDAL reads, with a CRS)"))
        self.addParameter(QgsProcessingParameterFeatureSource(
            "RELEASE", "Release polygon (field depth or volume)", [V.TypeVectorPolygon], optional=True))
        self.addParameter(QgsProcessingParameterFeatureSource(
            "HYDROGRAPH", "Or a hydrograph line (fields depth, discharge or volume + duration)",
            [V.TypeVectorLine], optional=True))
        self.addParameter(QgsProcessingParameterFeatureSource(
            "CHECK_DAMS", "Check dams (lines: name, crest_height, thickness)", [V.TypeVectorLine], optional=True))
        self.addParameter(QgsProcessingParameterFeatureSource(
            "STRUCTURE_AREAS", "Deposition areas and retention basins (polygons: type, name, ...)",
            [V.TypeVectorPolygon], optional=True))
        self.addParameter(QgsProcessingParameterFeatureSource(
            "ZONES", "Protected zones (polygons: name)", [V.TypeVectorPolygon], optional=True))
        self.addParameter(QgsProcessingParameterFeatureSource(
            "SECTIONS", "Cross-sections (lines: name; one named *outlet* is the compare table's outlet)",
            [V.TypeVectorLine], optional=True))
        self.addParameter(QgsProcessingParameterFeatureSource(
            "CORRIDOR", "Corridor polygon (default: runout's energy-line reach)", [V.TypeVectorPolygon], optional=True))
        self.addParameter(QgsProcessingParameterString("NAME", "Scene name", "qgis-scene"))
        self.addParameter(QgsProcessingParameterNumber("DP", "Particle spacing dp at standard fidelity (m)",
                                                       QgsProcessingParameterNumber.Double, 1.0, False, 1e-4, 100.0))
        self.addParameter(QgsProcessingParameterNumber("DURATION", "Simulated duration (s)",
                                                       QgsProcessingParameterNumber.Double, 60.0, False, 1e-3, 1e5))
        self.addParameter(QgsProcessingParameterEnum("FIDELITY", "Fidelity (draft = 2 dp, fine = dp / 2, "
                                                     "screening = the thickness-integrated model)",
                                                     list(FIDELITIES), defaultValue=0))
        for key, label, default, lo, hi in MATERIAL:
            self.addParameter(QgsProcessingParameterNumber(key, label, QgsProcessingParameterNumber.Double,
                                                           default, False, lo, hi))
        self._advanced(QgsProcessingParameterNumber(
            "SPEED_OF_SOUND", "Speed of sound c0 (m/s; 0: runout's conservative estimate)",
            QgsProcessingParameterNumber.Double, 0.0, False, 0.0, 1e5))
        self._advanced(QgsProcessingParameterNumber(
            "SERIES_INTERVAL", "Output sampling interval (s; 0: runout's default)",
            QgsProcessingParameterNumber.Double, 0.0, False, 0.0, 1e4))
        self._advanced(QgsProcessingParameterNumber(
            "INUNDATION_THRESHOLD", "Inundation threshold (m; 0: runout's default)",
            QgsProcessingParameterNumber.Double, 0.0, False, 0.0, 1e3))
        self._advanced(QgsProcessingParameterNumber("THREADS", "Threads (0: all cores)",
                                                    QgsProcessingParameterNumber.Integer, 0, False, 0, 1024))
        self.addParameter(QgsProcessingParameterFile("RUNOUT", "runout binary (default: $RUNOUT_BINARY or PATH)",
                                                     optional=True, fileFilter=ANY_FILE))
        self._advanced(QgsProcessingParameterFile("DB", "Run store for `runout run --db` (default: none)",
                                                  optional=True, fileFilter="SQLite (*.db)"))
        self.addParameter(QgsProcessingParameterString(
            "SERVICE_URL", "Or a runout service URL (http://host:8080)", optional=True))
        self.addParameter(QgsProcessingParameterFile(
            "TOKEN_FILE", "Service token file (default: $RUNOUT_TOKEN)", optional=True, fileFilter=ANY_FILE))
        self._advanced(QgsProcessingParameterString(
            "SERVICE_DEM", "The DEM's path on the service, relative to its --scene-dir (default: the DEM's file name)",
            optional=True))
        self.addParameter(QgsProcessingParameterFolderDestination("OUTPUT", "Output folder"))
        self.addOutput(QgsProcessingOutputFile("SCENE", "Scene written"))
        self.addOutput(QgsProcessingOutputFile("METRICS", "metrics.json"))
        self.addOutput(QgsProcessingOutputString("STATUS", "Run status"))
        self.addOutput(QgsProcessingOutputFile("HAZARD", "hazard.gpkg"))
        for r in runner.RASTERS:
            self.addOutput(QgsProcessingOutputRasterLayer(r.upper(), r))
        for v in HAZARD_LAYERS:
            self.addOutput(QgsProcessingOutputVectorLayer("HAZARD_" + v.upper(), "hazard " + v))

    # The scene --------------------------------------------------------------------------------------------------

    def _dem(self, parameters, context):
        dem = self.parameterAsRasterLayer(parameters, "DEM", context)
        path = dem.source().split("|")[0]
        if dem.providerType() != "gdal" or not os.path.isfile(path):
            raise QgsProcessingException(f"DEM: layer '{dem.name()}' is not a raster file (accepted: a file GDAL reads)")
        if not dem.crs().isValid():
            raise QgsProcessingException(f"DEM: {path} has no CRS (accepted: a DEM with a projected CRS in metres)")
        if dem.crs().isGeographic():  # runout would work in a UTM zone, and the scene's coordinates must be in it
            raise QgsProcessingException(f"DEM: {path} is in a geographic CRS ({dem.crs().authid()}) (accepted: a "
                                         "projected CRS in metres; reproject it with gdal:warpreproject first)")
        return dem, path

    def _source(self, parameters, key, context):
        return self.parameterAsSource(parameters, key, context) if parameters.get(key) else None

    def build_scene(self, parameters, context):
        """(scene dict, provenance) from the parameters."""
        dem, dem_path = self._dem(parameters, context)
        crs, prov = dem.crs(), scene.Provenance()
        num = {k: self.parameterAsDouble(parameters, k, context) for k, *_ in MATERIAL}
        material = {"name": "debris", "rheology": "friction-hbp",
                    **{MATERIAL_KEYS[k]: v for k, v in num.items()}}
        release, hydro = (self._source(parameters, k, context) for k in ("RELEASE", "HYDROGRAPH"))
        if (release is None) == (hydro is None):
            raise QgsProcessingException("RELEASE, HYDROGRAPH: give exactly one (accepted: a release polygon layer "
                                         "or a hydrograph line layer)")
        s = {"name": self.parameterAsString(parameters, "NAME", context),
             "description": f"Written by the Runout QGIS provider from the DEM {os.path.basename(dem_path)} and layers.",
             "dimensions": 3,
             "dp": self.parameterAsDouble(parameters, "DP", context),
             "duration": self.parameterAsDouble(parameters, "DURATION", context),
             "materials": [material],
             "terrain": {"dem": dem_path},
             "release": (scene.release_of(release, crs, context, prov, "debris") if release is not None
                         else scene.hydrograph_of(hydro, crs, context, prov, "debris"))}
        corridor = self._source(parameters, "CORRIDOR", context)
        if corridor is not None:
            s["terrain"]["corridor"] = scene.corridor_of(corridor, crs, context, prov)
        structures = []
        dams, areas = (self._source(parameters, k, context) for k in ("CHECK_DAMS", "STRUCTURE_AREAS"))
        if dams is not None:
            structures += scene.check_dams_of(dams, crs, context, prov, len(structures))
        if areas is not None:
            structures += scene.structure_areas_of(areas, crs, context, prov, len(structures))
        if structures:
            s["structures"] = structures
        zones, sections = (self._source(parameters, k, context) for k in ("ZONES", "SECTIONS"))
        if zones is not None:
            s["protected_zones"] = scene.zones_of(zones, crs, context, prov)
        if sections is not None:
            s["monitors"] = scene.sections_of(sections, crs, context, prov)
        c0 = self.parameterAsDouble(parameters, "SPEED_OF_SOUND", context)
        if c0 > 0:
            s["numerics"] = {"speed_of_sound": c0}
        output = {k: self.parameterAsDouble(parameters, p, context)
                  for k, p in (("series_interval", "SERIES_INTERVAL"), ("inundation_threshold", "INUNDATION_THRESHOLD"))}
        if any(v > 0 for v in output.values()):
            s["output"] = {k: v for k, v in output.items() if v > 0}
        return s, prov

    # Running ----------------------------------------------------------------------------------------------------

    def _run_local(self, parameters, context, feedback, scene_path, out_dir, fidelity, prov):
        binary = runner.find_binary(self.parameterAsFile(parameters, "RUNOUT", context))
        args = [binary, "run", scene_path, "--out", out_dir, "--fidelity", fidelity]
        threads = self.parameterAsInt(parameters, "THREADS", context)
        if threads > 0:
            args += ["--threads", str(threads)]
        db = self.parameterAsFile(parameters, "DB", context)
        args += ["--db", db] if db else ["--no-db"]
        rc, lines = runner.run_cli(args, feedback, runner.run_progress)
        refused = runner.refusal(lines)
        if rc == 2:
            raise QgsProcessingException("runout refused the scene: " + prov.explain(refused or "\n".join(lines[-5:])))
        if rc == 130:
            raise QgsProcessingException("cancelled: runout stopped the run (metrics.json status 'stopped')")
        if rc not in (0, 3):
            raise QgsProcessingException(f"runout run exited {rc}: " + "\n".join(lines[-5:]))

    def _run_service(self, parameters, context, feedback, s, out_dir, fidelity, prov, dem_path):
        url = self.parameterAsString(parameters, "SERVICE_URL", context)
        token = runner.read_token(self.parameterAsFile(parameters, "TOKEN_FILE", context))
        service = runner.Service(url, token)
        sent = json.loads(json.dumps(s))
        sent["terrain"]["dem"] = (self.parameterAsString(parameters, "SERVICE_DEM", context)
                                  or os.path.basename(dem_path))
        try:
            job = runner.run_job(service, {"scene": sent, "fidelity": fidelity}, feedback)
        except runner.ServiceError as e:
            raise QgsProcessingException(f"the service refused the scene ({e.status}): "
                                         + prov.explain(e.text.replace("scene.", "", 1))) from None
        if job["status"] == "cancelled":
            raise QgsProcessingException(f"cancelled: job {job['id']} was cancelled on the service")
        if job["status"] == "done" or job.get("run_id"):
            runner.fetch_results(service, job["id"], out_dir, feedback)
        if job["status"] != "done":
            raise QgsProcessingException(f"job {job['id']} {job['status']}: {job.get('error')}")

    def processAlgorithm(self, parameters, context, feedback):  # noqa: N802
        s, prov = self.build_scene(parameters, context)
        out_dir = self.parameterAsString(parameters, "OUTPUT", context)
        os.makedirs(out_dir, exist_ok=True)
        scene_path = os.path.join(out_dir, "scene.json")
        with open(scene_path, "w", encoding="utf-8") as f:
            json.dump(s, f, indent=2)
        feedback.pushInfo(f"scene written: {scene_path}")
        fidelity = FIDELITIES[self.parameterAsEnum(parameters, "FIDELITY", context)]
        if self.parameterAsString(parameters, "SERVICE_URL", context):
            self._run_service(parameters, context, feedback, s, out_dir, fidelity, prov, s["terrain"]["dem"])
        else:
            self._run_local(parameters, context, feedback, scene_path, out_dir, fidelity, prov)
        return self._results(out_dir, scene_path, s["name"], context, feedback)

    # Outputs ----------------------------------------------------------------------------------------------------

    def _results(self, out_dir, scene_path, name, context, feedback):
        metrics_path = os.path.join(out_dir, "metrics.json")
        with open(metrics_path, encoding="utf-8") as f:
            m = json.load(f)
        status = m.get("status")
        if status != "completed":
            raise QgsProcessingException(f"the run {status}: {m.get('error', '')} ({metrics_path})")
        rasters = os.path.join(out_dir, "rasters")
        hazard = os.path.join(rasters, "hazard.gpkg")
        results = {"OUTPUT": out_dir, "SCENE": scene_path, "METRICS": metrics_path, "STATUS": status,
                   "HAZARD": hazard}
        for r in runner.RASTERS:
            tif = os.path.join(rasters, r + ".tif")
            results[r.upper()] = tif
            self._load(context, tif, f"{name} {r}", r.upper(), _Style(os.path.join(rasters, r + ".qml")))
        for v in HAZARD_LAYERS:
            if v in _gpkg_layers(hazard):
                uri = f"{hazard}|layername={v}"
                results["HAZARD_" + v.upper()] = uri
                self._load(context, uri, f"{name} {v}", "HAZARD_" + v.upper(), None)
        return results

    def _load(self, context, uri, title, output, post):
        details = QgsProcessingContext.LayerDetails(title, context.project(), output)
        if post is not None:
            details.setPostProcessor(post)
            _POST_PROCESSORS.append(post)  # the context holds a bare pointer: keep the Python object alive
        context.addLayerToLoadOnCompletion(uri, details)
