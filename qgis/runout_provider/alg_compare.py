"""runout:comparelayouts: `runout sweep` (optional) then `runout compare --format json`, as a table layer with
one row per layout."""
import json
import os
import subprocess

from qgis.core import (QgsFeature, QgsFeatureSink, QgsField, QgsFields, QgsProcessing, QgsProcessingAlgorithm,
                       QgsProcessingException, QgsProcessingParameterBoolean, QgsProcessingParameterEnum,
                       QgsProcessingParameterFeatureSink, QgsProcessingParameterFile,
                       QgsProcessingParameterFolderDestination, QgsProcessingParameterNumber,
                       QgsProcessingParameterString, QgsWkbTypes)
from qgis.PyQt.QtCore import QVariant

from . import runner
from .runner import ANY_FILE

FIDELITIES = ("the sweep's own", "draft", "standard", "fine", "screening")


def table_of(compare):
    """`runout compare --format json` turned round: (field names, rows), one row per layout (the baseline
    first), a value and its per cent against the baseline per metric, and `<metric>_never` (1/0) for metrics
    where some layout's arrival never happened."""
    metrics = [r["metric"] for r in compare["rows"]]
    never = [r["metric"] for r in compare["rows"] if r["baseline_never"] or any(r["never"])]
    names = ["layout", "run_id", "baseline"] + [n for m in metrics for n in (m, m + "_pct")] + [m + "_never" for m in never]
    rows = [[compare["baseline"], compare["baseline_id"], 1]
            + [v for r in compare["rows"] for v in (r["baseline"], 0.0 if r["baseline"] is not None else None)]
            + [int(r["baseline_never"]) for r in compare["rows"] if r["metric"] in never]]
    for k, label in enumerate(compare["runs"]):
        rows.append([label, compare["run_ids"][k], 0]
                    + [v for r in compare["rows"] for v in (r["values"][k], r["percent"][k])]
                    + [int(r["never"][k]) for r in compare["rows"] if r["metric"] in never])
    return names, rows


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
                "See docs/qgis.md.")

    def createInstance(self):  # noqa: N802
        return CompareLayoutsAlgorithm()

    def initAlgorithm(self, config=None):  # noqa: N802
        self.addParameter(QgsProcessingParameterFile("SWEEP", "Sweep file (JSON: base scene and layouts)",
                                                     optional=True, fileFilter="JSON (*.json)"))
        self.addParameter(QgsProcessingParameterString("SWEEP_NAME", "Or the name of a sweep in the run store",
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
        self.addParameter(QgsProcessingParameterFolderDestination("RUNS", "Runs folder (runout sweep --out)"))
        self.addParameter(QgsProcessingParameterFeatureSink("OUTPUT", "Comparison", QgsProcessing.TypeVector))

    def _sweep(self, binary, sweep_file, db, runs, parameters, context, feedback):
        """Runs the sweep; returns its name (the file's `name`)."""
        try:
            with open(sweep_file, encoding="utf-8") as f:
                name = json.load(f)["name"]
        except (OSError, ValueError, KeyError) as e:
            raise QgsProcessingException(f"SWEEP: {sweep_file} is not a sweep file with a name ({e})") from None
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
        binary = runner.find_binary(self.parameterAsFile(parameters, "RUNOUT", context))
        sweep_file = self.parameterAsFile(parameters, "SWEEP", context)
        name = self.parameterAsString(parameters, "SWEEP_NAME", context)
        if bool(sweep_file) == bool(name):
            raise QgsProcessingException("SWEEP, SWEEP_NAME: give exactly one (accepted: a sweep file to run, or "
                                         "the name of a sweep already in the run store)")
        runs = self.parameterAsString(parameters, "RUNS", context)
        os.makedirs(runs, exist_ok=True)
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
        compare = json.loads(done.stdout)
        return {"OUTPUT": self._write(compare, parameters, context), "RUNS": runs}

    def _write(self, compare, parameters, context):
        names, rows = table_of(compare)
        fields = QgsFields()
        for n in names:
            fields.append(QgsField(n, QVariant.String if n == "layout" else
                                   QVariant.Int if n in ("run_id", "baseline") or n.endswith("_never")
                                   else QVariant.Double))
        sink, dest = self.parameterAsSink(parameters, "OUTPUT", context, fields, QgsWkbTypes.NoGeometry)
        if sink is None:
            raise QgsProcessingException(self.invalidSinkError(parameters, "OUTPUT"))
        for row in rows:
            f = QgsFeature(fields)
            f.setAttributes(row)
            sink.addFeature(f, QgsFeatureSink.FastInsert)
        return dest
