"""What every study shares: running scenarios on Dask (Runner), reading their outputs, references
and error measures, tables, plots and reports, and the StudyError that main() turns into an exit."""
import csv
import json
import math
import os
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass, field

import numpy as np
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402 - after matplotlib.use("Agg") (no display)

import distributed_runs  # noqa: E402 - a sibling of scripts/studies, on sys.path like studies itself


ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
EXIT_MEANING = {0: "ok", 2: "bad input", 3: "numerical failure", 4: "peer failure"}


class StudyError(Exception):
    """A study cannot go on: its message, and the exit code main() ends with (the run contract's:
    2 bad input, 3 numerical failure, 4 a peer or the cluster)."""

    def __init__(self, message, code=2):
        super().__init__(message)
        self.code = code


def fail(message, code=2):
    raise StudyError(message, code)


@dataclass(eq=False)  # (a run is itself: run_all tells kept runs by identity)
class Run:
    """One scenario run of a study: what to run (`scenario` with the overrides `sets`, into the
    folder `out`), the study's own coordinates of it (`labels`: its step, method, envelope
    point…), and once run (`record`) its outcome."""

    id: str
    scenario: str
    sets: list
    out: str
    labels: dict = field(default_factory=dict)
    reference: bool = False  # a study's reference run
    contact_probes: list = field(default_factory=list)  # probes whose nonzero samples are contacts
    # The outcome: the exit code (None: not run yet), the process's seconds, where it ran ("kept":
    # a kept run, --reuse), its summary.json, what failed, the time in its steps.
    code: int | None = None
    seconds: float = float("nan")
    host: str = ""
    summary: dict | None = None
    message: str = ""
    wall: float = float("nan")
    # What the study measured of it (errors, iterations, clearances…), by the study's names.
    measured: dict = field(default_factory=dict)

    @property
    def ok(self):
        return self.code == 0


class Runner:
    """Runs cosim_launch processes on Dask workers (distributed_runs: a local cluster of `jobs`
    workers, or the cluster at `scheduler`) and reports progress on stderr."""

    def __init__(self, bin_dir, jobs, scheduler=None, reuse=False):
        self.bin_dir = os.path.abspath(bin_dir)
        self.launch = os.path.join(self.bin_dir, "cosim_launch")
        if not os.access(self.launch, os.X_OK):
            fail(f"{self.launch} not found; build the project first (scripts/cosim setup)")
        self.jobs = max(1, jobs)
        self.scheduler = scheduler
        self.reuse = reuse  # keep a run whose folder already holds its summary (resuming a study)
        self._cluster = None

    def cluster(self):
        if self._cluster is None:
            try:
                self._cluster = distributed_runs.Cluster(self.jobs, self.scheduler)
            except ConnectionError as e:
                fail(f"--scheduler: {e}", 4)
            where = f"the Dask scheduler at {self.scheduler}" if self.scheduler else "a local Dask cluster"
            print(f"cosim study: runs go to {where} ({self._cluster.workers()} workers)", file=sys.stderr)
        return self._cluster

    def finished(self, run):
        """The run's folder holds a summary of this scenario with these overrides (the launcher's
        endpoints aside): the run as it was, its outputs read again."""
        summary = read_json(os.path.join(run.out, "summary.json"))
        if not summary or "exit_code" not in summary and "status" not in summary:
            return False
        overrides = [o for o in summary.get("overrides", []) if ".endpoint=" not in o]
        if not same_overrides(overrides, list(run.sets), os.path.join(run.out, "summary.json")):
            return False
        try:
            name = self.scenario_json(run.scenario, run.sets).get("name")
        except StudyError:
            return False
        if summary.get("scenario") != name:
            return False
        record(run, int(summary.get("exit_code", 0)), float(summary.get("wall_time", float("nan"))), "kept")
        return True

    def close(self):
        if self._cluster is not None:
            self._cluster.close()
            self._cluster = None

    def scenario_json(self, scenario, sets=()):
        args = [self.launch, scenario, "--print-scenario"]
        for s in sets:
            args += ["--set", s]
        p = subprocess.run(args, capture_output=True, text=True)
        if p.returncode != 0:
            fail(f"{scenario}: {p.stderr.strip()}", p.returncode)
        return json.loads(p.stdout)

    def run_all(self, runs):
        """Runs every Run (on the cluster, or kept with --reuse) and records its outcome; returns `runs`."""
        from distributed import as_completed

        total, done = len(runs), 0
        start = time.time()
        futures = {}
        kept = [r for r in runs if self.reuse and self.finished(r)]
        for run in kept:
            done += 1
            print(f"cosim study: [{done}/{total}] {run.id}: kept from {run.out} (--reuse)", file=sys.stderr)
        cluster = self.cluster() if len(kept) < len(runs) else None
        for run in runs:
            if run in kept:
                continue
            folder, name = os.path.split(os.path.abspath(run.scenario))
            job = {
                "scenario": name,
                "sets": list(run.sets),
                "files": distributed_runs.file_sets(run.sets),
                "bin_dir": self.bin_dir,
            }
            try:
                futures[cluster.submit(job, folder)] = run
            except ValueError as e:
                fail(str(e))
        for future in as_completed(list(futures)) if futures else []:
            run = futures[future]
            try:
                result = future.result()
            except Exception as e:  # noqa: BLE001 - a lost worker or a failed task is a data point
                result = {
                    "code": 4,
                    "seconds": float("nan"),
                    "host": "?",
                    "outputs": None,
                    "stderr": f"the Dask task failed: {type(e).__name__}: {e}",
                }
            shutil.rmtree(run.out, ignore_errors=True)
            if result["outputs"] is not None:
                distributed_runs.unpack(result["outputs"], run.out)
            record(run, result["code"], result["seconds"], result["host"], result["stderr"])
            done += 1
            status = "ok" if run.ok else f"FAILED (exit {run.code}: {EXIT_MEANING.get(run.code, '?')})"
            print(
                f"cosim study: [{done}/{total}] {run.id}: {status}; {total - done} left, "
                f"{time.time() - start:.1f} s so far",
                file=sys.stderr,
            )
        return runs


def same_overrides(recorded, wanted, summary_path):
    """A kept run's overrides (its summary's) are the ones asked for: equal, except that a file
    the run was sent (an absolute path, e.g. numerics.initial_state) is recorded at the worker's
    copy — the same name, and the file not rewritten since the run (a new settling run's state
    makes the runs from it run again)."""
    if len(recorded) != len(wanted):
        return False
    for r, w in zip(recorded, wanted):
        if r == w:
            continue
        rk, _, rv = r.partition("=")
        wk, _, wv = w.partition("=")
        rv, wv = rv.strip().strip('"'), wv.strip().strip('"')
        if rk != wk or not (os.path.isabs(wv) and os.path.isfile(wv)) or os.path.basename(rv) != os.path.basename(wv):
            return False
        if os.path.getmtime(wv) > os.path.getmtime(summary_path):
            return False
    return True


def record(run, code, seconds, host, stderr=""):
    """A Run's outcome, from its output folder: code, seconds (the process's), host, summary,
    message and wall."""
    run.code, run.seconds, run.host = code, seconds, host
    run.summary = read_json(os.path.join(run.out, "summary.json"))
    summary = run.summary or {}
    # What failed: the run's own reason (the coordinator's), else its last word.
    run.message = summary.get("reason", "") or (stderr.strip().splitlines() or [""])[-1]
    # The time in the time steps (the method's cost, without process start and output), else
    # the process's.
    run.wall = summary.get("step_wall_time") or summary.get("wall_time") or seconds


def run_scenario(scenario_path, spec):
    """The scenario file of a study's run spec (study.compare[i], a method's reference…): its
    `scenario`, relative to the study's scene, else the scene."""
    return os.path.join(os.path.dirname(scenario_path), spec["scenario"]) if spec.get("scenario") else scenario_path


def compare_run_scenario(scenario_path, spec, i):
    """run_scenario of study.compare[i], refused (exit 2) if the file is not there."""
    path = run_scenario(scenario_path, spec)
    if not os.path.isfile(path):
        fail(f"{scenario_path}: study.compare[{i}].scenario: no such file: {path}")
    return path


def read_json(path):
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError):
        return None


def read_histories(out):
    """Every probe of a run: the coordinator's history and each contact process's (subfolders),
    as {probe: (times, values)}."""
    probes = {}
    folders = (
        [out]
        + [os.path.join(out, d) for d in sorted(os.listdir(out)) if os.path.isfile(os.path.join(out, d, "history.csv"))]
        if os.path.isdir(out)
        else []
    )
    for folder in folders:
        path = os.path.join(folder, "history.csv")
        if os.path.isfile(path):
            for name, column in (history_table(path) or {}).items():
                probes.setdefault(name, column)
    return probes


def history_table(path):
    """A history CSV (a `time` column first, then one per probe) as {probe: (times, values)};
    None if it has no rows or its header does not start with `time`. ValueError if it is no
    CSV table."""
    data = np.genfromtxt(path, delimiter=",", names=True, ndmin=1)
    if data.size == 0 or data.dtype.names is None or data.dtype.names[0] != "time":
        return None
    return {n: (np.atleast_1d(data["time"]), np.atleast_1d(data[n])) for n in data.dtype.names[1:]}


SAFE_MATH = {k: getattr(math, k) for k in dir(math) if not k.startswith("_")}


def analytic(expression, times, where):
    try:
        code = compile(expression, where, "eval")
    except SyntaxError as e:
        fail(f"{where}: expression '{expression}' is not valid: {e.msg}")
    values = []
    for t in times:
        try:
            values.append(float(eval(code, {"__builtins__": {}}, dict(SAFE_MATH, t=float(t)))))
        except Exception as e:  # noqa: BLE001 - the user's expression
            fail(f"{where}: expression '{expression}' fails at t = {t}: {e}")
    return np.array(values)


class Reference:
    """The reference of each probe at any output time: analytic, or a reference run's history."""

    def __init__(self, study, history=None):
        self.expressions = {r["probe"]: r["expression"] for r in study.get("references", [])}
        self.history = history or {}

    def probes(self):
        return set(self.expressions) | set(self.history)

    def values(self, probe, times):
        if probe in self.expressions:
            return analytic(self.expressions[probe], times, f"study.references[{probe}]")
        t_ref, y_ref = self.history[probe]
        index = {round(t, 9): i for i, t in enumerate(t_ref)}
        out = []
        for t in times:
            i = index.get(round(t, 9))
            out.append(y_ref[i] if i is not None else np.interp(t, t_ref, y_ref))
        return np.array(out)


def probe_error(history, reference, probe, study):
    if probe not in history:
        return float("nan")
    t, y = history[probe]
    keep = t >= study.get("error_from", 0.0) - 1e-12
    t, y = t[keep], y[keep]
    if t.size == 0:
        return float("nan")
    if study.get("error", "MAX") == "END":
        t, y = t[-1:], y[-1:]
    return float(np.max(np.abs(y - reference.values(probe, t))))


def fitted_order(steps, errors):
    pts = [(math.log(h), math.log(e)) for h, e in zip(steps, errors) if e == e and e > 1e-14]
    if len(pts) < 2:
        return float("nan")
    x, y = zip(*pts)
    return float(np.polyfit(x, y, 1)[0])


def halving_steps(scenario, study):
    h0 = study.get("coarsest_step") or scenario["numerics"]["step"]
    k = max(4, int(study.get("halvings", 4)))
    return [h0 / 2**i for i in range(k + 1)]


def every_for(scenario, h, coarsest):
    """Output decimation so that every run writes the coarsest run's times (and no more)."""
    every = int(scenario.get("output", {}).get("every", 1))
    return max(1, int(round(every * coarsest / h)))


def reference_run(scenario_path, scenario, study, finest, coarsest, out, sets):
    """The run a study needs as its reference (None with analytic references), with the overrides
    every run of the study has (`sets`: the study's own and the command line's)."""
    if study.get("references"):
        return None
    if study.get("reference_run"):
        r = study["reference_run"]
        path = run_scenario(scenario_path, r)
        return Run(
            id=f"reference {r.get('name', '')}".strip(),
            scenario=path,
            sets=list(sets) + list(r.get("set", [])),
            out=os.path.join(out, "runs", "reference"),
            reference=True,
        )
    h = finest / int(study.get("reference_refinement", 4))
    return Run(
        id=f"reference h={h:.3g}",
        scenario=scenario_path,
        sets=list(sets) + [f"numerics.step={h!r}", f"output.every={every_for(scenario, h, coarsest)}"],
        out=os.path.join(out, "runs", "reference"),
        reference=True,
    )


def run_with_reference(runner, runs, reference, study, label):
    """Runs the study's runs and its reference run together; returns (runs, Reference, [reference run])."""
    done = runner.run_all(runs + ([reference] if reference else []))
    runs, extra = done[: len(runs)], done[len(runs) :]
    if not extra:
        return runs, Reference(study), []
    if not extra[0].ok:
        fail(f"the {label} reference run failed (exit {extra[0].code}): {extra[0].message}", 3)
    return runs, Reference(study, read_histories(extra[0].out)), extra


def run_and_measure(runner, runs, scenario_path, scenario, study, steps, out, label, sets):
    """Runs a study's runs with its reference; returns (runs, reference, reference runs,
    the runs' histories, the probes measured)."""
    runs, reference, extra = run_with_reference(
        runner, runs, reference_run(scenario_path, scenario, study, steps[-1], steps[0], out, sets), study, label
    )
    histories = [read_histories(r.out) if r.ok else {} for r in runs]
    probes = measured_probes(study, reference, histories)
    if not probes:
        fail("no probe to measure: give study.references or study.probes, or probes shared with the reference run")
    return runs, reference, extra, histories, probes


def measured_probes(study, reference, histories):
    if study.get("probes"):
        return list(study["probes"])
    if study.get("references"):
        return [r["probe"] for r in study["references"]]
    shared = None
    for h in histories:
        if h:
            shared = set(h) if shared is None else shared & set(h)
    return sorted((shared or set()) & reference.probes())


def write_csv(path, header, rows):
    with open(path, "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(header)
        w.writerows(rows)


def save_plot(fig, axes, path, legend_size=8):
    """Grid and legend on every axis, then the PNG."""
    for ax in axes:
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=legend_size)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def fmt(x):
    return "—" if x != x else f"{x:.3g}"


def with_study_sets(runner, scenario_path, sets):
    """The scenario as read, its study settings, and the overrides of every run (the study's own
    `set` first, the command line's after, so the command line wins)."""
    scenario = runner.scenario_json(scenario_path, sets)
    study = scenario.get("study", {})
    sets = list(study.get("set", [])) + list(sets)
    return runner.scenario_json(scenario_path, sets), study, sets


def start_from(state, time):
    """The overrides that start a run at `time` [s] from a saved state (a final_state.pb)."""
    return [f"numerics.start_time={time!r}", f'numerics.initial_state="{state}"']


def settled_start(runner, scenario_path, scenario, study, sets, out, why="the errors are those of the window alone"):
    """study.restart_time: one run of the scene up to that time (its own step, no output), whose
    final state every run of the study then starts from (numerics.initial_state); the overrides
    that make a run start there, and a line for the report.

    `sets` are the overrides of the whole study (study.set and the command line), never those of
    one kind of run (an envelope's own `set`): the settling run is the scene's start as the study
    describes it. A scene that settles its start (numerics.smooth.settle) settles in that run; the
    runs from its state are settled already and start with settle off (a run from a saved state
    that settles again is refused, exit 2: every point of an envelope failed so)."""
    restart = study.get("restart_time")
    if restart is None:
        return [], ""
    settles = bool(scenario.get("numerics", {}).get("smooth", {}).get("settle"))  # (as read with `sets`)
    settle = runner.run_all(
        [
            Run(
                id=f"settling to t = {restart:g} s",
                scenario=scenario_path,
                sets=list(sets) + [f"numerics.end_time={restart!r}", "output.every=1000000000"],
                out=os.path.join(out, "runs", "settle"),
            )
        ]
    )[0]
    state = os.path.abspath(os.path.join(settle.out, "final_state.pb"))
    if not settle.ok or not os.path.isfile(state):
        fail(f"the settling run to t = {restart:g} s failed (exit {settle.code}): {settle.message}", 3)
    return (
        start_from(state, restart) + (["numerics.smooth.settle=false"] if settles else []),
        f"Every run starts at t = {restart:g} s from the state of one settling run of the scene "
        f"(its own step, {settle.wall:.1f} s)"
        + (", whose start was settled as the scene asks (numerics.smooth.settle)" if settles else "")
        + f": {why}.",
    )


def default_methods(scenario):
    if scenario.get("model", {}).get("contact_nodes") and not scenario.get("model", {}).get("bodies"):
        return [{"name": f"Moreau–Jean, {s}", "set": [f"numerics.nonsmooth.lcp.solver={s}"]} for s in ("LEMKE", "PGS")]
    methods = [{"name": f"CGα ρ∞ = {r}", "set": [f"numerics.smooth.rho_inf={r}"]} for r in (0.9, 0.6, 0.0)]
    methods.append(
        {
            "name": "IDA",
            "set": ["numerics.smooth.integrator=IDA"],
            "sweep_field": "numerics.smooth.ida_relative_tolerance",
            "sweep_values": [1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9],
        }
    )
    return methods


def study_peer(scenario_path, study):
    """study.peer ({} if none), refused (exit 2) unless its wall and simulated times are > 0."""
    peer = study.get("peer") or {}
    if peer and not (peer.get("wall_time", 0) > 0 and peer.get("simulated_time", 0) > 0):
        fail(
            f"{scenario_path}: study.peer needs wall_time > 0 and simulated_time > 0 [s], "
            f"got {peer.get('wall_time')} and {peer.get('simulated_time')}"
        )
    return peer


def failures_section(runs):
    failed = [r for r in runs if r.code not in (0, None)]
    if not failed:
        return "Every run completed."
    out = ["Failed runs (data points, not errors of the study):", ""]
    for r in failed:
        out.append(f"- {r.id}: exit {r.code} ({EXIT_MEANING.get(r.code, '?')}): {r.message}")
    return "\n".join(out)


def report_head(title, scenario):
    """A study report's first lines: '# TITLE: scene name', a blank line, the scene's description."""
    return [f"# {title}: {scenario['name']}", "", scenario.get("description", ""), ""]


def write_report(out, lines):
    with open(os.path.join(out, "report.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    print(f"cosim study: report in {os.path.join(out, 'report.md')}", file=sys.stderr)


def contact_episodes(times, values, floor=0.0):
    """Runs of |value| > floor (a contact force, or a step's impulse): [(start, end, i0, i1)], with
    i0..i1 the samples inside; start/end are the first and last samples in contact."""
    episodes, start = [], None
    for i, v in enumerate(values):
        on = abs(v) > floor
        if on and start is None:
            start = i
        if not on and start is not None:
            episodes.append((times[start], times[i - 1], start, i - 1))
            start = None
    if start is not None:
        episodes.append((times[start], times[-1], start, len(values) - 1))
    return episodes
