"""runout:comparelayouts: `runout sweep` (optional) then `runout compare --format json`, or a sweep submitted to
the runout service and its `GET /compare`, as a table layer with one row per layout."""
import json
import os
import subprocess

from qgis.core import (QgsFeature, QgsFeatureSink, QgsField, QgsFields, QgsProcessing, QgsProcessingAlgorithm,
                       QgsProcessingException, QgsProcessingParameterBoolean, QgsProcessingParameterEnum,
                       QgsProcessingParameterDefinition, QgsProcessingParameterFeatureSink,
                       QgsProcessingParameterFile,
                       QgsProcessingParameterFolderDestination, QgsProcessingParameterNumber,
                       QgsProcessingParameterString, QgsWkbTypes)
from qgis.PyQt.QtCore import QVariant

from . import runner, tables
from .runner import ANY_FILE

FIDELITIES = ("the sweep's own", "draft", "standard", "fine", "screening")


class CompareLayoutsAlgorithm(QgsProcessingAlgorithm):
    def name(self):
        return "comparelayouts"

    def displayName(self):  # noqa: N802
        return "Run sweep / compare layouts"

    def group(self):
        return "Runout"

    def groupId(self):  # noqa: N802
        return "runout"

    def shortHelpString(self):  # noqa: N802
        return ("Runs a sweep file with `runout sweep` (layouts already in the run store are not run again) and "
                "returns `runout compare --format json` as a table: one row per layout, the baseline first, each "
                "decision metric's value and its per cent against the baseline (every stored metric with "
                "'All metrics'). Without a sweep file, compares the sweep NAME already in the run store. "
                "An ensemble sweep (runs LAYOUT-eNNN) gives per layout its share of first places and each "
                "decision metric's p10, p50, p90 over the members and how many never arrived; ensembles run "
                "with the local binary only (the service takes none yet). With a service URL the sweep is "
                "submitted to `runout serve` (the base scene sent inline, its DEM named as on the service) and "
                "its comparison fetched; NAME is then the newest sweep of that name on the service. "
                "See docs/qgis.md.")

    def createInstance(self):  # noqa: N802
        return CompareLayoutsAlgorithm()

    def _advanced(self, p):
        p.setFlags(p.flags() | QgsProcessingParameterDefinition.FlagAdvanced)
        self.addParameter(p)

    def initAlgorithm(self, config=None):  # noqa: N802
        self.addParameter(QgsProcessingParameterFile("SWEEP", "Sweep file (JSON: base scene and layouts)",
                                                     optional=True, fileFilter="JSON (*.json)"))
        self.addParameter(QgsProcessingParameterString("SWEEP_NAME", "Or the name of a sweep in the run store (or on the service)",
                                                       optional=True))
        self.addParameter(QgsProcessingParameterEnum("FIDELITY", "Fidelity", list(FIDELITIES), defaultValue=0))
        self.addParameter(QgsProcessingParameterFile("DB", "Run store (default: runout.db in the runs folder)",
                                                     optional=True, fileFilter="SQLite (*.db)"))
        self.addParameter(QgsProcessingParameterString("BASELINE", "Baseline layout (default: the first by name)",
                                                       optional=True))
        self.addParameter(QgsProcessingParameterBoolean("ALL", "All metrics (not only the decision metrics)", False))
        self.addParameter(QgsProcessingParameterNumber("JOBS", "Layouts run at once", QgsProcessingParameterNumber.Integer,
                                                       1, False, 1, 256))
        self.addParameter(QgsProcessingParameterNumber("THREADS", "Threads per layout (0: the cores divided among "
                                                       "the layouts run at once)", QgsProcessingParameterNumber.Integer,
                                                       0, False, 0, 1024))
        self.addParameter(QgsProcessingParameterFile("RUNOUT", "runout binary (default: $RUNOUT_BINARY or PATH)",
                                                     optional=True, fileFilter=ANY_FILE))
        self.addParameter(QgsProcessingParameterString(
            "SERVICE_URL", "Or a runout service URL (http://host:8080; not for ensembles)", optional=True))
        self.addParameter(QgsProcessingParameterFile(
            "TOKEN_FILE", "Service token file (default: $RUNOUT_TOKEN)", optional=True, fileFilter=ANY_FILE))
        self._advanced(QgsProcessingParameterString(
            "SERVICE_DEM", "The base scene's DEM on the service, relative to its --scene-dir (default: the DEM's "
            "file name)", optional=True))
        self.addParameter(QgsProcessingParameterFolderDestination("RUNS", "Runs folder (runout sweep --out)"))
        self.addParameter(QgsProcessingParameterFeatureSink("OUTPUT", "Comparison", QgsProcessing.TypeVector))

    def _sweep(self, binary, sweep_file, db, runs, parameters, context, feedback):
        """Runs the sweep; returns its name (the file's `name`)."""
        name = _read_sweep(sweep_file)["name"]
        args = [binary, "sweep", sweep_file, "--db", db, "--out", runs,
                "--jobs", str(self.parameterAsInt(parameters, "JOBS", context))]
        threads = self.parameterAsInt(parameters, "THREADS", context)
        if threads > 0:
            args += ["--threads", str(threads)]
        fidelity = self.parameterAsEnum(parameters, "FIDELITY", context)
        if fidelity > 0:
            args += ["--fidelity", FIDELITIES[fidelity]]
        rc, lines = runner.run_cli(args, feedback, runner.sweep_progress)
        if rc == 130:
            raise QgsProcessingException("cancelled: runout stopped the sweep (finished layouts are stored)")
        if rc != 0:  # the failed layouts' lines name the reason; else runout's last words
            failed = [line for line in lines if runner.SWEEP_DONE.match(line) and " failed " in line]
            raise QgsProcessingException(f"runout sweep exited {rc}: " + "\n".join(failed or lines[-5:]))
        return name

    def processAlgorithm(self, parameters, context, feedback):  # noqa: N802
        sweep_file = self.parameterAsFile(parameters, "SWEEP", context)
        name = self.parameterAsString(parameters, "SWEEP_NAME", context)
        if bool(sweep_file) == bool(name):
            raise QgsProcessingException("SWEEP, SWEEP_NAME: give exactly one (accepted: a sweep file to run, or "
                                         "the name of a sweep already in the run store or on the service)")
        runs = self.parameterAsString(parameters, "RUNS", context)
        os.makedirs(runs, exist_ok=True)
        if self.parameterAsString(parameters, "SERVICE_URL", context):
            compare = self._compare_service(sweep_file, name, runs, parameters, context, feedback)
        else:
            compare = self._compare_local(sweep_file, name, runs, parameters, context, feedback)
        return {"OUTPUT": self._write(compare, parameters, context), "RUNS": runs}

    def _compare_local(self, sweep_file, name, runs, parameters, context, feedback):
        binary = runner.find_binary(self.parameterAsFile(parameters, "RUNOUT", context))
        db = self.parameterAsFile(parameters, "DB", context) or os.path.join(runs, "runout.db")
        if sweep_file:
            name = self._sweep(binary, sweep_file, db, runs, parameters, context, feedback)
        args = [binary, "compare", "--sweep", name, "--format", "json", "--db", db]
        baseline = self.parameterAsString(parameters, "BASELINE", context)
        if baseline:
            args += ["--baseline", baseline]
        if self.parameterAsBool(parameters, "ALL", context):
            args.append("--all")
        feedback.pushCommandInfo(" ".join(args))
        done = subprocess.run(args, capture_output=True, text=True)
        if done.returncode != 0:
            raise QgsProcessingException(f"runout compare exited {done.returncode}: {done.stderr[-500:]}")
        return json.loads(done.stdout)

    # The service --------------------------------------------------------------------------------------------

    def _compare_service(self, sweep_file, name, runs, parameters, context, feedback):
        """Submits the sweep file (or finds the newest sweep NAME), follows it and returns its comparison in the
        shape of `runout compare --format json`; the service's own document is kept in RUNS."""
        service = runner.Service(self.parameterAsString(parameters, "SERVICE_URL", context),
                                 runner.read_token(self.parameterAsFile(parameters, "TOKEN_FILE", context)))
        if sweep_file:
            body = self._sweep_request(sweep_file, parameters, context)
            try:
                sweep = service.json("POST", "/sweeps", body)
            except runner.ServiceError as e:
                raise _refused(e, "SWEEP", f"the sweep {sweep_file}") from None
            feedback.pushInfo(f"sweep {sweep['id']} ({sweep['name']}, {len(sweep['jobs'])} layouts) submitted to "
                              f"{service.base}")
        else:
            sweep = runner.find_sweep(service, name)
            if sweep is None:
                raise QgsProcessingException(f"SWEEP_NAME: the service at {service.base} has no sweep named '{name}'")
            feedback.pushInfo(f"sweep {sweep['id']} ({name}) found on {service.base}")
        sweep = runner.run_sweep(service, sweep, feedback)
        _check_finished(sweep)
        doc = self._service_compare(service, sweep, parameters, context)
        with open(os.path.join(runs, f"compare-sweep-{sweep['id']}.json"), "w", encoding="utf-8") as f:
            json.dump(doc, f, indent=2)
        return tables.cli_compare_of_service(doc, self.parameterAsBool(parameters, "ALL", context))

    def _sweep_request(self, sweep_file, parameters, context):
        """POST /sweeps's body from a sweep file: its base scene inline (the service reads files only inside
        its --scene-dir, so the DEM is renamed as SERVICE_DEM says), its layouts and fidelity."""
        doc = _read_sweep(sweep_file)
        if "ensemble" in doc:
            raise QgsProcessingException(f"SWEEP: {sweep_file} is an ensemble sweep; the service takes no ensemble "
                                         "yet (accepted with SERVICE_URL: a sweep without `ensemble`; run it with "
                                         "the local binary)")
        base = doc.get("base")
        if isinstance(base, str):
            path = os.path.join(os.path.dirname(os.path.abspath(sweep_file)), base)
            try:
                with open(path, encoding="utf-8") as f:
                    base = json.load(f)
            except (OSError, ValueError) as e:
                raise QgsProcessingException(f"SWEEP: the base scene {path} cannot be read ({e})") from None
        if not isinstance(base, dict):
            raise QgsProcessingException(f"SWEEP: {sweep_file}'s base must be a scene file name (accepted: a "
                                         "string, relative to the sweep file)")
        dem = (base.get("terrain") or {}).get("dem")
        if isinstance(dem, str):
            base["terrain"]["dem"] = (self.parameterAsString(parameters, "SERVICE_DEM", context)
                                      or os.path.basename(dem))
        body = {"name": doc["name"], "base": base}
        for key in ("variants", "factorial", "fidelity"):
            if key in doc:
                body[key] = doc[key]
        fidelity = self.parameterAsEnum(parameters, "FIDELITY", context)
        if fidelity > 0:
            body["fidelity"] = FIDELITIES[fidelity]
        return body

    def _service_compare(self, service, sweep, parameters, context):
        """GET /compare?sweep=ID, the baseline the BASELINE layout's job (default: the first layout by name, as
        `runout compare` takes it)."""
        jobs = {v["variant"]: v["job"] for v in sweep["variants"]}
        baseline = self.parameterAsString(parameters, "BASELINE", context) or min(jobs)
        if baseline not in jobs:
            raise QgsProcessingException(f"BASELINE: '{baseline}' is not a layout of sweep {sweep['id']} (accepted: "
                                         + ", ".join(sorted(jobs)) + ")")
        try:
            return service.json("GET", f"/compare?sweep={sweep['id']}&baseline={jobs[baseline]}")
        except runner.ServiceError as e:
            raise _refused(e, "BASELINE" if e.text.startswith("baseline") else "SWEEP",
                           f"the comparison of sweep {sweep['id']}") from None

    # The table ----------------------------------------------------------------------------------------------

    def _write(self, compare, parameters, context):
        if tables.is_ensemble(compare):
            try:
                names, rows = tables.ensemble_table_of(compare, self.parameterAsString(parameters, "BASELINE", context))
            except ValueError as e:
                raise QgsProcessingException(f"BASELINE: {e}") from None
        else:
            names, rows = tables.table_of(compare)
        kinds = {"text": QVariant.String, "int": QVariant.Int, "double": QVariant.Double}
        fields = QgsFields()
        for n in names:
            fields.append(QgsField(n, kinds[tables.field_kind(n)]))
        sink, dest = self.parameterAsSink(parameters, "OUTPUT", context, fields, QgsWkbTypes.NoGeometry)
        if sink is None:
            raise QgsProcessingException(self.invalidSinkError(parameters, "OUTPUT"))
        for row in rows:
            f = QgsFeature(fields)
            f.setAttributes(row)
            sink.addFeature(f, QgsFeatureSink.FastInsert)
        return dest


def _read_sweep(sweep_file):
    try:
        with open(sweep_file, encoding="utf-8") as f:
            doc = json.load(f)
        if not isinstance(doc, dict) or not isinstance(doc.get("name"), str):
            raise ValueError("no string `name`")
    except (OSError, ValueError) as e:
        raise QgsProcessingException(f"SWEEP: {sweep_file} is not a sweep file with a name ({e})") from None
    return doc


def _refused(e, parameter, what):
    """A service's problem document as the error of the parameter it concerns: the token for 401/403."""
    if e.status in (401, 403):
        parameter = "TOKEN_FILE"
    hint = " (SERVICE_DEM: the DEM's path relative to the service's --scene-dir)" if "terrain.dem" in e.text else ""
    return QgsProcessingException(f"{parameter}: the service refused {what} ({e.status}): {e.text}{hint}")


def _check_finished(sweep):
    """A sweep that did not end done: which layouts failed or were cancelled, with the service's reason."""
    if sweep["status"] == "done":
        return
    bad = [v for v in sweep["variants"] if v["status"] != "done"]
    if all(v["status"] == "cancelled" for v in bad):
        raise QgsProcessingException(f"cancelled: sweep {sweep['id']}'s unfinished layouts were cancelled on the "
                                     "service (" + ", ".join(v["variant"] for v in bad) + "; finished ones are stored)")
    raise QgsProcessingException(f"sweep {sweep['id']} {sweep['status']}: " + "; ".join(
        f"layout {v['variant']} {v['status']}: {v.get('error') or ''}" for v in bad))
