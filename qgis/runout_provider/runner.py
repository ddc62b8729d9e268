"""Drives runout: the local binary as a subprocess, or the HTTP service (docs/service.md), with progress and
cancellation through QgsProcessingFeedback."""
import json
import os
import queue
import re
import shutil
import signal
import subprocess
import threading
import time
import urllib.error
import urllib.request

from qgis.core import QgsProcessingException

# A file parameter's filter for names without an extension (the default, "*.*", refuses `runout`).
ANY_FILE = "All files (*)"
RASTERS = ("max_depth", "max_speed", "deposit_depth", "max_hv", "arrival_time", "max_pressure", "intensity")

# `runout run` off a terminal prints a line every 10 % ("... 40.0%  t=1.4/3.5 s ..."); `runout sweep` a line
# per finished run ("[3/8] ...").
RUN_PERCENT = re.compile(r"\]\s+(\d+(?:\.\d+)?)%\s+t=")
SWEEP_DONE = re.compile(r"^\[(\d+)/(\d+)\]")
REFUSED = re.compile(r"scene refused: (.*)$")


def find_binary(given):
    """The runout binary: the parameter, else $RUNOUT_BINARY, else `runout` on PATH."""
    path = given or os.environ.get("RUNOUT_BINARY") or shutil.which("runout")
    if not path or not os.access(path, os.X_OK):
        raise QgsProcessingException(f"runout binary: {path or 'not found'} is not an executable "
                                     "(accepted: the RUNOUT parameter, $RUNOUT_BINARY, or runout on PATH)")
    return path


def _reader(stream, lines):
    for line in iter(stream.readline, ""):
        lines.put(line)
    lines.put(None)


def run_cli(args, feedback, progress_of):
    """Runs `runout ARGS`, echoing its output to the log and its progress to the bar; Cancel sends SIGINT
    (runout stops cleanly, exit 130). Returns (exit code, every line)."""
    feedback.pushCommandInfo(" ".join(args))
    proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, bufsize=1)
    lines, seen = queue.Queue(), []
    threading.Thread(target=_reader, args=(proc.stdout, lines), daemon=True).start()
    interrupted = False
    while True:
        if feedback.isCanceled() and not interrupted:
            proc.send_signal(signal.SIGINT)
            interrupted = True
        try:
            line = lines.get(timeout=0.2)
        except queue.Empty:
            continue
        if line is None:
            break
        seen.append(line.rstrip("\n"))
        feedback.pushConsoleInfo(seen[-1])
        p = progress_of(seen[-1])
        if p is not None:
            feedback.setProgress(p)
    rc = proc.wait()
    proc.stdout.close()
    return rc, seen


def run_progress(line):
    m = RUN_PERCENT.search(line)
    return float(m.group(1)) if m else None


def sweep_progress(line):
    m = SWEEP_DONE.search(line)
    return 100.0 * int(m.group(1)) / int(m.group(2)) if m else None


def refusal(lines):
    """runout's `scene refused: FIELD: ...` line, or None."""
    for line in lines:
        m = REFUSED.search(line)
        if m:
            return m.group(1)
    return None


def read_token(token_file):
    """The bearer token from a file (first non-empty line) or $RUNOUT_TOKEN; never a plain parameter, so it
    stays out of the Processing history and logs."""
    if token_file:
        with open(token_file, encoding="utf-8") as f:
            for line in f:
                if line.strip():
                    return line.strip()
        raise QgsProcessingException(f"token file: {token_file} holds no token (accepted: a file whose first "
                                     "non-empty line is the service's bearer token)")
    return os.environ.get("RUNOUT_TOKEN") or None


class Service:
    """The few calls of the jobs API the provider needs."""

    def __init__(self, url, token):
        self.base = url.rstrip("/")
        if not self.base.endswith("/api/v1"):
            self.base += "/api/v1"
        self.token = token

    def _request(self, method, path, body=None):
        headers = {"Accept": "application/json"}
        data = None
        if body is not None:
            data = json.dumps(body).encode()
            headers["Content-Type"] = "application/json"
        if self.token and method != "GET":
            headers["Authorization"] = "Bearer " + self.token
        req = urllib.request.Request(self.base + path, data=data, method=method, headers=headers)
        try:
            with urllib.request.urlopen(req, timeout=60) as r:
                return r.read()
        except urllib.error.HTTPError as e:
            raise ServiceError(e.code, e.read()) from None
        except urllib.error.URLError as e:
            raise QgsProcessingException(f"service URL: {self.base} cannot be reached ({e.reason})") from None

    def json(self, method, path, body=None):
        return json.loads(self._request(method, path, body))

    def download(self, path, dest):
        with open(dest, "wb") as f:
            f.write(self._request("GET", path))


class ServiceError(QgsProcessingException):
    """An RFC 9457 problem document from the service: every invalid field with its message."""

    def __init__(self, status, body):
        try:
            problem = json.loads(body)
            errors = [f"{e['field']}: {e['message']}" for e in problem.get("errors", [])]
            text = "; ".join(errors) or problem.get("detail", "")
        except (ValueError, KeyError, TypeError):
            text = body[:500].decode(errors="replace")
        self.status, self.text = status, text
        super().__init__(f"service answered {status}: {text}")


def run_job(service, body, feedback, poll_s=1.0):
    """Submits a job and follows it to its end; Cancel deletes it. Returns the finished job."""
    job = service.json("POST", "/jobs", body)
    feedback.pushInfo(f"job {job['id']} submitted to {service.base}")
    cancelled = False
    while job["status"] in ("queued", "running"):
        if feedback.isCanceled() and not cancelled:
            service.json("DELETE", f"/jobs/{job['id']}")
            cancelled = True
        time.sleep(poll_s)
        job = service.json("GET", f"/jobs/{job['id']}")
        frac = (job.get("progress") or {}).get("fraction")
        if frac is not None:
            feedback.setProgress(100.0 * frac)
    return job


ACTIVE = ("queued", "running")


def run_sweep(service, sweep, feedback, poll_s=1.0):
    """Follows a sweep on the service (anything with its `id`) to its end: the mean progress of its layouts drives the
    bar. The service has no route that cancels a sweep, so Cancel DELETEs each of its unfinished jobs (docs/
    service.md, DELETE /jobs/{id}); the running ones stop within a step. Returns the sweep (GET /sweeps/{id})."""
    cancelled = False
    while True:
        sweep = service.json("GET", f"/sweeps/{sweep['id']}")
        feedback.setProgress(100.0 * sweep["progress"]["fraction"])
        if sweep["status"] != "running":
            return sweep
        if feedback.isCanceled() and not cancelled:
            cancel_jobs(service, sweep, feedback)
            cancelled = True
        time.sleep(poll_s)


def cancel_jobs(service, sweep, feedback):
    for v in sweep["variants"]:
        if v["status"] not in ACTIVE:
            continue
        try:
            service.json("DELETE", f"/jobs/{v['job']}")
            feedback.pushInfo(f"cancelling layout {v['variant']} (job {v['job']})")
        except ServiceError as e:  # 409: it finished meanwhile
            feedback.pushWarning(f"layout {v['variant']} (job {v['job']}) not cancelled: {e.text}")


def find_sweep(service, name):
    """The newest sweep named `name` on the service (GET /sweeps, newest first, page by page), or None."""
    path = "/sweeps?limit=1000"
    while path:
        page = service.json("GET", path)
        for s in page["sweeps"]:
            if s["name"] == name:
                return s
        nxt = page.get("next")  # "/api/v1/sweeps?...&cursor=...": the path after the base
        path = nxt[nxt.index("/sweeps"):] if nxt else None
    return None


def fetch_results(service, job_id, out_dir, feedback):
    """The job's metrics.json, rasters with their styles and hazard.gpkg into out_dir, laid out as
    `runout run --out` lays them out."""
    rasters = os.path.join(out_dir, "rasters")
    os.makedirs(rasters, exist_ok=True)
    metrics = service.json("GET", f"/jobs/{job_id}/metrics")["metrics_json"]
    with open(os.path.join(out_dir, "metrics.json"), "w", encoding="utf-8") as f:
        json.dump(metrics, f, indent=2)
    for name in RASTERS:
        service.download(f"/jobs/{job_id}/rasters/{name}.tif", os.path.join(rasters, name + ".tif"))
        try:
            service.download(f"/jobs/{job_id}/rasters/{name}.qml", os.path.join(rasters, name + ".qml"))
        except ServiceError as e:  # a service from before the styles were served
            feedback.pushWarning(f"{name}.qml: {e.text}")
    service.download(f"/jobs/{job_id}/vectors/hazard.gpkg", os.path.join(rasters, "hazard.gpkg"))
    return metrics
