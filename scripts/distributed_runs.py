"""Runs of a study on Dask distributed (Debian's python3-distributed).

A run is one `cosim_launch SCENARIO --out DIR --set ...` process. The study sends each run to a
Dask worker as a task that carries everything the run reads: the scenario's folder (every file
under it, so that `study.compare`, `reference_run` and `c81_file` paths relative to the scenario
resolve) and any file an override names by an absolute path (e.g. the settling run's
`numerics.initial_state`). The worker unpacks them into a temporary folder, runs its own
`cosim_launch` (from COSIM_BIN_DIR in the worker's environment, else the client's build folder:
the same path on every machine) and sends the run's output folder back, which the client unpacks
where the study expects it. A run that fails (any exit code, a lost worker) is a data point.

Where the runs go: a LocalCluster of `jobs` single-threaded worker processes on this machine by
default, or the scheduler at `--scheduler ADDRESS` (tcp://host:8786), whose workers must have the
project built (scripts/cosim setup) and Python 3 with python3-distributed; the task code itself is
shipped by value (cloudpickle), so the workers need nothing of scripts/.
"""
import io
import os
import socket
import subprocess
import sys
import tarfile
import tempfile
import time

# The whole scenario folder goes with every run; refuse one that is a data dump by mistake.
MAX_BUNDLE_BYTES = 64 * 1024 * 1024


def pack(path, arcname="."):
    """A folder (or file) as gzipped tar bytes."""
    buffer = io.BytesIO()
    with tarfile.open(fileobj=buffer, mode="w:gz", compresslevel=3) as tar:
        tar.add(path, arcname=arcname)
    return buffer.getvalue()


def unpack(data, destination):
    """Gzipped tar bytes into a folder, refusing members that would land outside it."""
    os.makedirs(destination, exist_ok=True)
    root = os.path.realpath(destination)
    with tarfile.open(fileobj=io.BytesIO(data), mode="r:gz") as tar:
        for member in tar.getmembers():
            target = os.path.realpath(os.path.join(destination, member.name))
            if target != root and not target.startswith(root + os.sep):
                raise ValueError(f"archive member '{member.name}' leaves {destination}")
            if member.issym() or member.islnk():
                raise ValueError(f"archive member '{member.name}' is a link")
        tar.extractall(destination)


def run_on_worker(job, bundle):
    """The task: runs one scenario from its shipped folder and returns the outputs (on a worker)."""
    bin_dir = os.environ.get("COSIM_BIN_DIR") or job["bin_dir"]
    launch = os.path.join(bin_dir, "cosim_launch")
    host = socket.gethostname()
    if not os.access(launch, os.X_OK):
        return {
            "code": 4,
            "seconds": 0.0,
            "host": host,
            "outputs": None,
            "stderr": f"worker {host}: no cosim_launch at {launch} (build the project there, or set "
            f"COSIM_BIN_DIR in the worker's environment)",
        }
    with tempfile.TemporaryDirectory(prefix="cosim-run-") as tmp:
        unpack(bundle, os.path.join(tmp, "scene"))
        sets = list(job["sets"])
        for name, data in job["files"].items():
            # Under the same absolute path below tmp/files: a coupled state keeps its layout.
            path = os.path.join(tmp, "files", name.lstrip(os.sep))
            os.makedirs(os.path.dirname(path), exist_ok=True)
            with open(path, "wb") as f:
                f.write(data)
            sets = [s.replace(name, path) for s in sets]
        out = os.path.join(tmp, "out")
        args = [launch, os.path.join(tmp, "scene", job["scenario"]), "--out", out]
        for s in sets:
            args += ["--set", s]
        t0 = time.time()
        p = subprocess.run(args, capture_output=True, text=True)
        seconds = time.time() - t0
        outputs = pack(out) if os.path.isdir(out) else None
        # The worker's temporary paths mean nothing to the client: name the scene's instead.
        stderr = p.stderr.replace(os.path.join(tmp, "scene") + os.sep, "")
        return {"code": p.returncode, "seconds": seconds, "host": host, "outputs": outputs, "stderr": stderr}


class Cluster:
    """The Dask client of a study: a LocalCluster of `jobs` workers, or a running scheduler."""

    def __init__(self, jobs, scheduler=None):
        import cloudpickle
        from distributed import Client, LocalCluster

        # Ship this module's code with each task: workers need not have scripts/ on their path.
        cloudpickle.register_pickle_by_value(sys.modules[__name__])
        self.cluster = None
        if scheduler:
            try:
                self.client = Client(scheduler, timeout="20s")
            except (OSError, TimeoutError) as e:
                raise ConnectionError(f"no Dask scheduler at {scheduler}: {e}") from e
        else:
            self.cluster = LocalCluster(
                n_workers=jobs, threads_per_worker=1, processes=True, dashboard_address=None, silence_logs=40
            )
            self.client = Client(self.cluster)
        self.address = self.client.scheduler.address
        self._bundles = {}

    def workers(self):
        return len(self.client.scheduler_info().get("workers", {}))

    def bundle(self, folder):
        """The scenario folder, packed and sent to the cluster once per study."""
        if folder not in self._bundles:
            size = sum(os.path.getsize(os.path.join(d, f)) for d, _, fs in os.walk(folder) for f in fs)
            if size > MAX_BUNDLE_BYTES:
                raise ValueError(
                    f"{folder}: the scenario folder holds {size / 2**20:.0f} MiB; a study ships it "
                    f"to every worker, at most {MAX_BUNDLE_BYTES / 2**20:.0f} MiB (move the scenario "
                    f"into a folder of its own)"
                )
            self._bundles[folder] = self.client.scatter(pack(folder), broadcast=False, hash=False)
        return self._bundles[folder]

    def submit(self, job, folder):
        return self.client.submit(run_on_worker, job, self.bundle(folder), pure=False)

    def close(self):
        self.client.close()
        if self.cluster is not None:
            self.cluster.close()


def file_sets(sets):
    """The files an override names by an existing absolute path ({path: bytes}), shipped with
    the run (e.g. numerics.initial_state="/…/final_state.pb"); with a final_state.pb, the contact
    processes' states in the folders beside it (a coupled run's, NAME/final_state.pb)."""
    files = {}
    for s in sets:
        _, _, value = s.partition("=")
        path = value.strip().strip('"').strip("'")
        if not (os.path.isabs(path) and os.path.isfile(path)):
            continue
        shipped = [path]
        if os.path.basename(path) == "final_state.pb":
            folder = os.path.dirname(path)
            shipped += sorted(
                os.path.join(folder, d, "final_state.pb")
                for d in os.listdir(folder)
                if os.path.isfile(os.path.join(folder, d, "final_state.pb"))
            )
        for name in shipped:
            with open(name, "rb") as f:
                files[name] = f.read()
    return files
