#!/usr/bin/python3
"""Studies of a scenario: scripts/cosim study KIND SCENARIO [options].

KIND
  convergence     sweep the time step (halvings), error of each probe against a reference
                  (analytic expressions of the scenario's `study`, or a much finer run),
                  observed order per probe as a fitted slope
  work-precision  error against wall time for each method (study.methods; default CGα with
                  ρ∞ = 0.9, 0.6, 0 and IDA), one curve per method, the same error measure
  coupling        coupling iterations per step, residual histories and wall time as the
                  relaxation, the reaction tolerance and the step vary (a coupled scenario)
  stability       the hard-case table: SCENARIO is a folder of scenarios (or one file); does
                  each complete, constraint violation, energy change, iterations, wall time
  compare         runs of one scene on the same axes (study.compare: e.g. co-simulated and
                  continuous stops), their RMS and peak differences and each stop contact
  envelope        the scene over a grid of one or two named quantities (study.envelope: e.g.
                  gust peak × direction), per point the tips' lowest and highest heights,
                  clearance to a plane, peak stop force and impacts; polar or grid plots
  timing          wall time of the scene's runs (study.compare, else the scene) with and
                  without output, one at a time, per simulated second and against study.peer
  results         every study of docs/results.md, regenerated into docs/

Each study writes into its output folder (default runs/study/KIND-NAME): runs.csv (one row per
run), PNG plots and report.md embedding them. Runs are independent processes (cosim_launch)
run on Dask distributed: a local cluster of --jobs workers (default: the number of cores), or
the cluster at --scheduler ADDRESS, each run's scenario folder shipped to its worker and its
outputs brought back (distributed_runs.py); a failed run is a data point.
"""
import argparse
import csv
import json
import math
import os
import re
import shutil
import subprocess
import sys
import time

import numpy as np
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import distributed_runs  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
EXIT_MEANING = {0: "ok", 2: "bad input", 3: "numerical failure", 4: "peer failure"}


def fail(message, code=2):
    print(f"cosim study: error: {message}", file=sys.stderr)
    sys.exit(code)


# ---------------------------------------------------------------------------------------------
# Running
# ---------------------------------------------------------------------------------------------


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
        summary = read_json(os.path.join(run["out"], "summary.json"))
        if not summary or "exit_code" not in summary and "status" not in summary:
            return False
        overrides = [o for o in summary.get("overrides", []) if ".endpoint=" not in o]
        if not same_overrides(overrides, list(run["sets"]), os.path.join(run["out"], "summary.json")):
            return False
        try:
            name = self.scenario_json(run["scenario"], run["sets"]).get("name")
        except SystemExit:
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
        """runs: list of dicts with id, scenario, sets, out. Adds code, wall, summary, seconds, host."""
        from distributed import as_completed

        total, done = len(runs), 0
        start = time.time()
        futures = {}
        kept = [r for r in runs if self.reuse and self.finished(r)]
        for run in kept:
            done += 1
            print(f"cosim study: [{done}/{total}] {run['id']}: kept from {run['out']} (--reuse)", file=sys.stderr)
        cluster = self.cluster() if len(kept) < len(runs) else None
        for run in runs:
            if run in kept:
                continue
            folder, name = os.path.split(os.path.abspath(run["scenario"]))
            job = {
                "scenario": name,
                "sets": list(run["sets"]),
                "files": distributed_runs.file_sets(run["sets"]),
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
            shutil.rmtree(run["out"], ignore_errors=True)
            if result["outputs"] is not None:
                distributed_runs.unpack(result["outputs"], run["out"])
            record(run, result["code"], result["seconds"], result["host"], result["stderr"])
            done += 1
            status = "ok" if run["code"] == 0 else f"FAILED (exit {run['code']}: {EXIT_MEANING.get(run['code'], '?')})"
            print(
                f"cosim study: [{done}/{total}] {run['id']}: {status}; {total - done} left, "
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
    """A run's outcome into its dict, from its output folder: code, seconds (the process's),
    host, summary, message and wall."""
    run["code"], run["seconds"], run["host"] = code, seconds, host
    run["summary"] = read_json(os.path.join(run["out"], "summary.json"))
    summary = run["summary"] or {}
    # What failed: the run's own reason (the coordinator's), else its last word.
    run["message"] = summary.get("reason", "") or (stderr.strip().splitlines() or [""])[-1]
    # The time in the time steps (the method's cost, without process start and output), else
    # the process's.
    run["wall"] = summary.get("step_wall_time") or summary.get("wall_time") or seconds


def run_scenario(scenario_path, run):
    """The scenario file of a study's Run: its `scenario`, relative to the study's scene, else the scene."""
    return os.path.join(os.path.dirname(scenario_path), run["scenario"]) if run.get("scenario") else scenario_path


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


# ---------------------------------------------------------------------------------------------
# Errors against a reference
# ---------------------------------------------------------------------------------------------

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


# ---------------------------------------------------------------------------------------------
# Studies
# ---------------------------------------------------------------------------------------------


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
        return {
            "id": f"reference {r.get('name', '')}".strip(),
            "scenario": path,
            "sets": list(sets) + list(r.get("set", [])),
            "out": os.path.join(out, "runs", "reference"),
            "reference": True,
        }
    h = finest / int(study.get("reference_refinement", 4))
    return {
        "id": f"reference h={h:.3g}",
        "scenario": scenario_path,
        "sets": list(sets) + [f"numerics.step={h!r}", f"output.every={every_for(scenario, h, coarsest)}"],
        "out": os.path.join(out, "runs", "reference"),
        "reference": True,
    }


def run_with_reference(runner, runs, reference, study, label):
    """Runs the study's runs and its reference run together; returns (runs, Reference, [reference run])."""
    done = runner.run_all(runs + ([reference] if reference else []))
    runs, extra = done[: len(runs)], done[len(runs) :]
    if not extra:
        return runs, Reference(study), []
    if extra[0]["code"] != 0:
        fail(f"the {label} reference run failed (exit {extra[0]['code']}): {extra[0]['message']}", 3)
    return runs, Reference(study, read_histories(extra[0]["out"])), extra


def run_and_measure(runner, runs, scenario_path, scenario, study, steps, out, label, sets):
    """Runs a study's runs with its reference; returns (runs, reference, reference runs,
    the runs' histories, the probes measured)."""
    runs, reference, extra = run_with_reference(
        runner, runs, reference_run(scenario_path, scenario, study, steps[-1], steps[0], out, sets), study, label
    )
    histories = [read_histories(r["out"]) if r["code"] == 0 else {} for r in runs]
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


def settled_start(runner, scenario_path, study, sets, out, why="the errors are those of the window alone"):
    """study.restart_time: one run of the scene up to that time (its own step, no output), whose
    final state every run of the study then starts from (numerics.initial_state); the overrides
    that make a run start there, and a line for the report."""
    restart = study.get("restart_time")
    if restart is None:
        return [], ""
    settle = runner.run_all(
        [
            {
                "id": f"settling to t = {restart:g} s",
                "scenario": scenario_path,
                "sets": list(sets) + [f"numerics.end_time={restart!r}", "output.every=1000000000"],
                "out": os.path.join(out, "runs", "settle"),
            }
        ]
    )[0]
    state = os.path.abspath(os.path.join(settle["out"], "final_state.pb"))
    if settle["code"] != 0 or not os.path.isfile(state):
        fail(f"the settling run to t = {restart:g} s failed (exit {settle['code']}): {settle['message']}", 3)
    return (
        start_from(state, restart),
        f"Every run starts at t = {restart:g} s from the state of one settling run of the scene "
        f"(its own step, {settle['wall']:.1f} s): {why}.",
    )


def study_convergence(runner, scenario_path, out, sets):
    scenario, study, sets = with_study_sets(runner, scenario_path, sets)
    restart_sets, restart_note = settled_start(runner, scenario_path, study, sets, out)
    sets = list(sets) + restart_sets
    steps = halving_steps(scenario, study)
    runs = [
        {
            "id": f"h={h:.4g}",
            "h": h,
            "scenario": scenario_path,
            "sets": list(sets) + [f"numerics.step={h!r}", f"output.every={every_for(scenario, h, steps[0])}"],
            "out": os.path.join(out, "runs", f"h{i}"),
        }
        for i, h in enumerate(steps)
    ]
    runs, reference, extra, histories, probes = run_and_measure(
        runner, runs, scenario_path, scenario, study, steps, out, "convergence", sets
    )
    errors = {
        p: [probe_error(hist, reference, p, study) if hist else float("nan") for hist in histories] for p in probes
    }
    orders = {p: fitted_order(steps, errors[p]) for p in probes}
    write_csv(
        os.path.join(out, "runs.csv"),
        ["run", "step", "exit", "wall_time"] + [f"error_{p}" for p in probes],
        [[r["id"], r["h"], r["code"], r["wall"]] + [errors[p][i] for p in probes] for i, r in enumerate(runs)],
    )
    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    for p in probes:
        ok = [(h, e) for h, e in zip(steps, errors[p]) if e == e and e > 0]
        if ok:
            ax.loglog(*zip(*ok), "o-", label=f"{p} (order {orders[p]:.2f})")
    h = np.array(steps)
    finite = [e for p in probes for e in errors[p] if e == e and e > 0]
    if finite:
        anchor = max(finite)
        ax.loglog(h, anchor * (h / h[0]) ** 2, "k:", label="slope 2")
        ax.loglog(h, anchor * (h / h[0]), "k--", lw=0.8, label="slope 1")
    ax.set_xlabel("time step h [s]")
    ax.set_ylabel(f"error ({'max over time' if study.get('error', 'MAX') == 'MAX' else 'at the end'}) [probe units]")
    ax.set_title(f"{scenario['name']}: convergence")
    save_plot(fig, [ax], os.path.join(out, "convergence.png"))
    lines = [
        f"# Convergence: {scenario['name']}",
        "",
        scenario.get("description", ""),
        "",
        f"Reference: {'analytic (study.references)' if study.get('references') else 'a finer run' if not study.get('reference_run') else 'study.reference_run'}; "
        f"error: {study.get('error', 'MAX')} over the output times from t = {study.get('error_from', 0)} s.",
        "",
        *([restart_note, ""] if restart_note else []),
        "![convergence](convergence.png)",
        "",
        "| probe | " + " | ".join(f"h = {h:.4g}" for h in steps) + " | fitted order |",
        "|---|" + "---|" * (len(steps) + 1),
    ]
    for p in probes:
        lines.append(f"| {p} | " + " | ".join(fmt(e) for e in errors[p]) + f" | {orders[p]:.2f} |")
    lines += ["", failures_section(runs + extra)]
    write_report(out, lines)
    return {"orders": orders, "errors": errors, "steps": steps, "runs": runs}


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


def stop_contacts(history, contact_probes, gap):
    """A run's stop contacts: [start, end] of the runs of non-zero samples of its contact probes
    (together), those apart by at most `gap` [s] merged into one (a bounce train)."""
    episodes = []
    for cp in contact_probes:
        if cp in history:
            t, v = history[cp]
            episodes += [(float(a), float(b)) for a, b, _, _ in contact_episodes(t, v)]
    merged = []
    for a, b in sorted(episodes):
        if merged and a - merged[-1][1] <= gap:
            merged[-1][1] = max(merged[-1][1], b)
        else:
            merged.append([a, b])
    return merged


def peak_in(history, probe, a, b):
    t, v = history[probe]
    window = (t >= a - 1e-9) & (t <= b + 1e-9)
    return float(np.max(np.abs(v[window]))) if window.any() else float("nan")


def event_errors(history, contacts, reference, reference_contacts, events):
    """The event measures of one run against its reference (study.events): {measure: error}, and
    the number of stop contacts that do not pair (the reference's without a run contact within
    merge_gap of its start, and the run's left over)."""
    gap = float(events.get("merge_gap", 0.05))
    mine, theirs = stop_contacts(history, contacts, gap), stop_contacts(reference, reference_contacts, gap)
    first = min(t[0] for t, _ in reference.values()) if reference else 0.0
    last = max(t[-1] for t, _ in reference.values()) if reference else 0.0
    out = {"contact times": 0.0}
    out.update({f"peak {p}": 0.0 for p in events.get("peak_probes", [])})
    unpaired, used = 0, set()
    for a, b in theirs:
        candidates = [i for i in range(len(mine)) if i not in used and abs(mine[i][0] - a) <= max(gap, 1e-9)]
        if not candidates:
            unpaired += 1
            continue
        i = min(candidates, key=lambda k: abs(mine[k][0] - a))
        used.add(i)
        c, d = mine[i]
        if a > first + 1e-9:  # a re-contact (not the contact the run starts in)
            out["contact times"] = max(out["contact times"], abs(c - a))
        if b < last - 1e-9:  # a lift-off (not the contact the run ends in)
            out["contact times"] = max(out["contact times"], abs(d - b))
        for p in events.get("peak_probes", []):
            if p in history and p in reference:
                out[f"peak {p}"] = max(out[f"peak {p}"], abs(peak_in(history, p, c, d) - peak_in(reference, p, a, b)))
    return out, unpaired + len(mine) - len(used)


def study_work_precision_events(runner, scenario_path, scenario, study, sets, runs, methods, out):
    """work-precision with study.events: each method against its own reference, each measure apart."""
    events = study["events"]
    peer = study_peer(scenario_path, study)
    references, keys, reference_of = [], {}, {}  # reference_of: method name → index in references
    for m, method in enumerate(methods):
        spec = method.get("reference") or study.get("reference_run")
        if not spec:
            fail(
                f"{scenario_path}: study.methods[{m}] ('{method['name']}'): study.events needs a reference run "
                "(study.methods[].reference or study.reference_run)"
            )
        key = json.dumps(spec, sort_keys=True)
        if key not in keys:
            keys[key] = len(references)
            references.append(
                {
                    "id": f"reference {spec.get('name', len(references))}",
                    "reference": True,
                    "scenario": run_scenario(scenario_path, spec),
                    "sets": list(sets) + list(spec.get("set", [])),
                    "contact_probes": list(spec.get("contact_probes", [])),
                    "out": os.path.join(out, "runs", f"reference{len(references)}"),
                }
            )
        reference_of[method["name"]] = keys[key]
    done = runner.run_all(references + runs)  # (the references first: a study cut short can be resumed with --reuse)
    references, runs = done[: len(references)], done[len(references) :]
    for r in references:
        if r["code"] != 0:
            fail(f"the work-precision reference run '{r['id']}' failed (exit {r['code']}): {r['message']}", 3)
    ref_histories = [read_histories(r["out"]) for r in references]
    ref_values = [Reference(study, h) for h in ref_histories]
    by_name = {method["name"]: method for method in methods}
    measures = (
        [f"history {p}" for p in events.get("history_probes", [])]
        + ["contact times"]
        + [f"peak {p}" for p in events.get("peak_probes", [])]
    )
    for r in runs:
        k = reference_of[r["method"]]
        reference, ref_run = ref_histories[k], references[k]
        r["errors"], r["unpaired"] = {m: float("nan") for m in measures}, float("nan")
        if r["code"] != 0:
            continue
        history = read_histories(r["out"])
        for p in events.get("history_probes", []):
            r["errors"][f"history {p}"] = (
                probe_error(history, ref_values[k], p, study) if p in reference else float("nan")
            )
        found, r["unpaired"] = event_errors(
            history, by_name[r["method"]].get("contact_probes", []), reference, ref_run["contact_probes"], events
        )
        r["errors"].update(found)
    write_csv(
        os.path.join(out, "runs.csv"),
        ["run", "method", "swept_value", "exit", "wall_time", "unpaired_contacts"] + [f"error {m}" for m in measures],
        [
            [r["id"], r["method"], r["value"], r["code"], r["wall"], r["unpaired"]] + [r["errors"][m] for m in measures]
            for r in runs
        ],
    )
    # One panel per measure: error against the wall time of the steps, a line per method; a
    # peer's wall time for the same simulated span (study.peer) marked for scale.
    simulated = float(scenario["numerics"]["end_time"]) - float(scenario["numerics"].get("start_time", 0.0))
    peer_wall = peer["wall_time"] * simulated / peer["simulated_time"] if peer else None
    columns = 2
    rows = (len(measures) + columns - 1) // columns
    fig, axes = plt.subplots(rows, columns, figsize=(11, 3.6 * rows), squeeze=False)
    units = {"contact times": "[s]"}
    for ax, measure in zip(axes.flat, measures):
        for method in methods:
            pts = sorted(
                (r["wall"], r["errors"][measure])
                for r in runs
                if r["method"] == method["name"]
                and r["errors"][measure] == r["errors"][measure]
                and r["errors"][measure] > 0
            )
            if pts:
                ax.loglog(*zip(*pts), "o-", label=method["name"])
        if peer_wall:
            ax.axvline(peer_wall, color="k", ls=":", lw=1.0, label=f"{peer.get('name', 'peer')}: wall time")
        ax.axvline(simulated, color="0.6", ls="--", lw=0.8, label="real time")
        ax.set_title(f"{measure} {units.get(measure, '')}", fontsize=9)
        ax.set_xlabel("wall time of the time steps [s]", fontsize=8)
        ax.set_ylabel("error against the reference", fontsize=8)
    for ax in list(axes.flat)[len(measures) :]:
        ax.axis("off")
    fig.suptitle(f"{scenario['name']}: work against precision", fontsize=10)
    save_plot(fig, [ax for ax in axes.flat if ax.has_data()], os.path.join(out, "work_precision.png"), legend_size=7)
    lines = [
        f"# Work against precision: {scenario['name']}",
        "",
        scenario.get("description", ""),
        "",
        "Each method against its own reference run ("
        + "; ".join(f"'{m['name']}': {references[reference_of[m['name']]]['id']}" for m in methods)
        + "). Measures: "
        "the largest |value − reference| of each history probe over the output times; the largest error of a "
        "stop contact's start (re-contact) or end (lift-off) time; the largest error of the peak of each peak "
        f"probe within a stop contact (contacts apart by at most {events.get('merge_gap', 0.05)} s are one). "
        "Wall time: the time steps' (summary.json step_wall_time; a coupled run: the coordinator's, which "
        "includes waiting for its peers)"
        + (
            f"; {peer.get('name')}: {peer_wall:.0f} s for the same " f"{simulated:g} s ({peer.get('source', '')})."
            if peer_wall
            else "."
        ),
        "",
        "![work-precision](work_precision.png)",
        "",
        "| method | swept | wall [s] | unpaired contacts | " + " | ".join(measures) + " |",
        "|---|---|---|---|" + "---|" * len(measures),
    ]
    for r in runs:
        lines.append(
            f"| {r['method']} | {r['value']:.3g} | {r['wall']:.3g} | {fmt(r['unpaired'])} | "
            + " | ".join(fmt(r["errors"][m]) for m in measures)
            + " |"
        )
    lines += ["", failures_section(runs + references)]
    write_report(out, lines)
    return {"runs": runs, "measures": measures}


def study_work_precision(runner, scenario_path, out, sets):
    scenario, study, sets = with_study_sets(runner, scenario_path, sets)
    steps = halving_steps(scenario, study)
    methods = study.get("methods") or default_methods(scenario)
    runs = []
    for m, method in enumerate(methods):
        path = run_scenario(scenario_path, method)
        field = method.get("sweep_field", "numerics.step")
        values = method.get("sweep_values") or steps
        for i, v in enumerate(values):
            extra = [f"{field}={v!r}"]
            if field == "numerics.smooth.ida_relative_tolerance":
                extra.append(f"numerics.smooth.ida_absolute_tolerance={v!r}")
            if field == "numerics.adaptive.relative":  # adaptive CGα: output on the coarsest grid, every step
                extra += [f"numerics.adaptive.absolute={v!r}", "numerics.adaptive.enabled=true"]
                # (unless the method asks for sparser rows: a coupled adaptive run's steps land on them)
                if not any(x.startswith("output.every=") for x in method.get("set", [])):
                    extra.append("output.every=1")
            if field == "numerics.step":
                extra.append(f"output.every={every_for(scenario, v, steps[0])}")
            else:  # output on the coarsest grid
                extra += [f"numerics.step={steps[0]!r}"]
            runs.append(
                {
                    "id": f"{method['name']} {field.split('.')[-1]}={v:.3g}",
                    "method": method["name"],
                    "value": v,
                    "scenario": path,
                    "sets": list(sets) + list(method.get("set", [])) + extra,
                    "out": os.path.join(out, "runs", f"m{m}_{i}"),
                }
            )
    if study.get("events"):
        return study_work_precision_events(runner, scenario_path, scenario, study, sets, runs, methods, out)
    runs, reference, extra_runs, histories, probes = run_and_measure(
        runner, runs, scenario_path, scenario, study, steps, out, "work-precision", sets
    )
    for r, hist in zip(runs, histories):
        errs = [probe_error(hist, reference, p, study) for p in probes] if hist else [float("nan")]
        r["error"] = max(errs) if all(e == e for e in errs) else float("nan")
    write_csv(
        os.path.join(out, "runs.csv"),
        ["run", "method", "swept_value", "exit", "wall_time", "error"],
        [[r["id"], r["method"], r["value"], r["code"], r["wall"], r["error"]] for r in runs],
    )
    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    for method in methods:
        pts = sorted(
            (r["wall"], r["error"])
            for r in runs
            if r["method"] == method["name"] and r["error"] == r["error"] and r["error"] > 0
        )
        if pts:
            ax.loglog(*zip(*pts), "o-", label=method["name"])
    ax.set_xlabel("wall time of the time steps [s]")
    ax.set_ylabel("error, largest over the probes [probe units]")
    ax.set_title(f"{scenario['name']}: work against precision\n({', '.join(probes)})", fontsize=10)
    save_plot(fig, [ax], os.path.join(out, "work_precision.png"))
    lines = [
        f"# Work against precision: {scenario['name']}",
        "",
        scenario.get("description", ""),
        "",
        f"Error: the largest over {', '.join(probes)} of {study.get('error', 'MAX')} |value − reference|; "
        f"reference: {'analytic' if study.get('references') else 'a reference run'}; wall time of the time steps "
        f"(summary.json step_wall_time; a coupled run: the coordinator's, which includes waiting for its peers).",
        "",
        "![work-precision](work_precision.png)",
        "",
        "| method | swept | wall [s] | error |",
        "|---|---|---|---|",
    ]
    for r in runs:
        lines.append(f"| {r['method']} | {r['value']:.3g} | {r['wall']:.3g} | {fmt(r['error'])} |")
    lines += ["", failures_section(runs + extra_runs)]
    write_report(out, lines)
    return {"runs": runs, "probes": probes}


def relaxation_sets(spec):
    """'AITKEN', 'CONSTANT(0.05)' (the factor ω) or 'IQN_ILS(4)' (secants kept 4 steps)."""
    name, _, arg = spec.partition("(")
    name, arg = name.strip(), arg.rstrip(")").strip()
    if name not in ("CONSTANT", "AITKEN", "IQN_ILS"):
        fail(f"study.relaxations: '{spec}': expected CONSTANT(ω), AITKEN or IQN_ILS(q)")
    out = [f"coupling.iteration.relaxation={name}"]
    if arg and name in ("CONSTANT", "AITKEN"):
        out.append(f"coupling.iteration.relaxation_factor={arg}")
    elif arg:
        out.append(f"coupling.iteration.reuse_steps={arg}")
    return out


def study_coupling(runner, scenario_path, out, sets):
    scenario, study, sets = with_study_sets(runner, scenario_path, sets)
    if not scenario.get("coupling", {}).get("interface_nodes"):
        fail(f"{scenario_path}: the coupling study needs a coupled scenario (coupling.interface_nodes)")
    h0 = study.get("coarsest_step") or scenario["numerics"]["step"]
    relaxations = study.get("relaxations") or ["CONSTANT", "AITKEN", "IQN_ILS"]
    tolerances = study.get("tolerances") or [1e-4, 1e-6, 1e-8]
    steps = study.get("steps") or [h0, h0 / 2]
    runs = []
    for relax in relaxations:
        for tol in tolerances:
            for h in steps:
                runs.append(
                    {
                        "id": f"{relax} tol={tol:g} h={h:g}",
                        "relaxation": relax,
                        "tol": tol,
                        "h": h,
                        "scenario": scenario_path,
                        "sets": list(sets)
                        + relaxation_sets(relax)
                        + [f"coupling.iteration.reaction_tolerance={tol!r}", f"numerics.step={h!r}"],
                        "out": os.path.join(
                            out, "runs", f"{relax}_{tol:g}_{h:g}".replace(".", "p").replace("(", "_").replace(")", "")
                        ),
                    }
                )
    runs = runner.run_all(runs)
    for r in runs:
        it = (r["summary"] or {}).get("coupling_iterations", {})
        r["mean"], r["max"] = it.get("mean_per_step", float("nan")), it.get("max_per_step", float("nan"))
    write_csv(
        os.path.join(out, "runs.csv"),
        ["run", "relaxation", "reaction_tolerance", "step", "exit", "mean_iterations", "max_iterations", "wall_time"],
        [[r["id"], r["relaxation"], r["tol"], r["h"], r["code"], r["mean"], r["max"], r["wall"]] for r in runs],
    )
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for c, relax in enumerate(relaxations):
        for h, style in zip(steps, ("o-", "s--", "^:", "v-.")):
            kw = {"color": colours[c % len(colours)], "label": f"{relax}, h = {h:g} s"}
            pts = [(r["tol"], r["mean"]) for r in runs if r["relaxation"] == relax and r["h"] == h and r["code"] == 0]
            if pts:
                axes[0].semilogx(*zip(*sorted(pts)), style, **kw)
            pts = [(r["tol"], r["wall"]) for r in runs if r["relaxation"] == relax and r["h"] == h and r["code"] == 0]
            if pts:
                axes[1].loglog(*zip(*sorted(pts)), style, **kw)
    axes[0].set_xlabel("reaction tolerance (relative)")
    axes[0].set_ylabel("coupling iterations per step (mean)")
    axes[1].set_xlabel("reaction tolerance (relative)")
    axes[1].set_ylabel("wall time [s]")
    fig.suptitle(f"{scenario['name']}: coupling iterations (failed runs left out, see the table)")
    save_plot(fig, axes, os.path.join(out, "iterations.png"), legend_size=7)
    # Residual histories: the step with the most iterations, tightest tolerance, coarsest step.
    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    for relax in relaxations:
        match = [r for r in runs if r["relaxation"] == relax and r["tol"] == min(tolerances) and r["h"] == steps[0]]
        path = os.path.join(match[0]["out"], "coupling.csv") if match else ""
        if not os.path.isfile(path):
            continue
        log = np.genfromtxt(path, delimiter=",", names=True, ndmin=1)
        if log.size == 0:
            continue
        counts = np.bincount(log["step"].astype(int))
        worst = int(np.argmax(counts))
        rows = log[log["step"] == worst]
        ax.semilogy(
            rows["iteration"],
            np.maximum(rows["reaction_residual"], 1e-16),
            "o-",
            label=f"{relax}: step {worst} ({len(rows)} iterations)",
        )
    ax.set_xlabel("coupling iteration")
    ax.set_ylabel("reaction residual |x̃ − x|∞ [N]")
    ax.set_title(f"{scenario['name']}: the hardest step, tolerance {min(tolerances):g}")
    save_plot(fig, [ax], os.path.join(out, "residuals.png"))
    lines = [
        f"# Coupling: {scenario['name']}",
        "",
        scenario.get("description", ""),
        "",
        "![iterations](iterations.png)",
        "",
        "![residuals](residuals.png)",
        "",
        "| relaxation | reaction tolerance | step [s] | exit | iterations/step (mean) | max | wall [s] |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in runs:
        lines.append(
            f"| {r['relaxation']} | {r['tol']:g} | {r['h']:g} | {r['code']} ({EXIT_MEANING.get(r['code'], '?')}) | "
            f"{fmt(r['mean'])} | {fmt(r['max'])} | {r['wall']:.3g} |"
        )
    lines += ["", failures_section(runs)]
    write_report(out, lines)
    return {"runs": runs}


def study_stability(runner, target, out, sets):
    if os.path.isdir(target):
        scenarios = sorted(os.path.join(target, f) for f in os.listdir(target) if f.endswith(".pbtxt"))
    else:
        scenarios = [target]
    if not scenarios:
        fail(f"{target}: no .pbtxt scenarios")
    infos, runs = {}, []
    for i, path in enumerate(scenarios):
        scenario = runner.scenario_json(path, sets)
        infos[path] = scenario
        runs.append(
            {
                "id": scenario["name"],
                "scenario": path,
                "sets": list(sets),
                "out": os.path.join(out, "runs", scenario["name"]),
            }
        )
    runs = runner.run_all(runs)
    rows = []
    for r in runs:
        scenario = infos[r["scenario"]]
        s = r["summary"] or {}
        energy = [
            p["name"] for p in scenario.get("output", {}).get("probes", []) if p.get("quantity") == "TOTAL_ENERGY"
        ]
        drift = float("nan")
        if energy:
            hist = read_histories(r["out"])
            if energy[0] in hist and hist[energy[0]][1].size > 1:
                e = hist[energy[0]][1]
                drift = float(np.max(np.abs(e - e[0])))  # [J]: a scene may start at E = 0
        iters = []
        for key, label in (
            ("newton_iterations", "Newton"),
            ("coupling_iterations", "coupling"),
            ("lcp_iterations", "LCP"),
        ):
            if s.get(key, {}).get("mean_per_step") is not None and s.get(key, {}).get("total", 0):
                iters.append(f"{label} {s[key]['mean_per_step']:.2f}")
        rows.append(
            {
                "name": scenario["name"],
                "reason": scenario.get("study", {}).get("reason") or scenario.get("description", ""),
                "code": r["code"],
                "completes": r["code"] == 0,
                "violation": s.get("max_constraint_violation", float("nan")),
                "drift": drift,
                "iterations": ", ".join(iters) or "—",
                "wall": r["wall"],
                "steps": s.get("steps", 0),
                "message": r["message"] if r["code"] != 0 else "",
            }
        )
    write_csv(
        os.path.join(out, "runs.csv"),
        [
            "scenario",
            "exit",
            "completes",
            "steps",
            "max_constraint_violation",
            "energy_drift",
            "iterations_per_step",
            "wall_time",
            "reason",
            "message",
        ],
        [
            [
                x["name"],
                x["code"],
                x["completes"],
                x["steps"],
                x["violation"],
                x["drift"],
                x["iterations"],
                x["wall"],
                x["reason"],
                x["message"],
            ]
            for x in rows
        ],
    )
    lines = [
        "# Stability: the hard cases",
        "",
        "Each scene is run once as shipped. Energy change: the largest |E(t) − E(0)| [J] of its TOTAL_ENERGY probe:",
        "a drift where the scene conserves energy, the dissipation where it should dissipate (impacts with e < 1).",
        "",
        "| scene | what it tests | completes | largest constraint violation | energy change [J] | iterations per step | wall [s] |",
        "|---|---|---|---|---|---|---|",
    ]
    for x in rows:
        done = "yes" if x["completes"] else f"**no** (exit {x['code']}: {x['message']})"
        lines.append(
            f"| {x['name']} | {x['reason']} | {done} | {fmt(x['violation'])} | {fmt(x['drift'])} | "
            f"{x['iterations']} | {x['wall']:.3g} |"
        )
    write_report(out, lines)
    return {"rows": rows}


def failures_section(runs):
    failed = [r for r in runs if r.get("code", 0) != 0]
    if not failed:
        return "Every run completed."
    out = ["Failed runs (data points, not errors of the study):", ""]
    for r in failed:
        out.append(f"- {r['id']}: exit {r['code']} ({EXIT_MEANING.get(r['code'], '?')}): {r['message']}")
    return "\n".join(out)


def write_report(out, lines):
    with open(os.path.join(out, "report.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    print(f"cosim study: report in {os.path.join(out, 'report.md')}", file=sys.stderr)


# ---------------------------------------------------------------------------------------------
# docs/results.md
# ---------------------------------------------------------------------------------------------


def results(runner, out_root, sets, reuse=False):
    """The studies behind docs/results.md, their reports copied next to it."""
    docs = os.path.join(ROOT, "docs")
    figures = os.path.join(docs, "results")
    os.makedirs(figures, exist_ok=True)
    sections = []
    plan = [
        ("convergence", "four_bar", "scenarios/four_bar.pbtxt"),
        ("work-precision", "four_bar", "scenarios/four_bar.pbtxt"),
        ("work-precision", "linear_oscillator", "scenarios/linear_oscillator.pbtxt"),
        ("work-precision", "pendulum_stop", "scenarios/pendulum_stop.pbtxt"),
        ("coupling", "pendulum_stop", "scenarios/pendulum_stop.pbtxt"),
        ("stability", "hard", "scenarios/hard"),
        ("stability", "scenarios", "scenarios"),
        ("compare", "puma_gust", "scenarios/puma/gust.pbtxt"),
        ("compare", "puma_engage", "scenarios/puma/engage_disengage.pbtxt"),
        # MBDyn's histories of the same rotor beside the engagement modelled as MBDyn models it
        # (issue 33), with each of MBDyn's aerodynamic choices undone in turn.
        ("compare", "puma_mbdyn", "scenarios/puma/engage_disengage_mbdyn.pbtxt"),
        ("timing", "puma_engage", "scenarios/puma/engage_disengage.pbtxt"),
        # The engagement's error against wall time, each model against its converged run (issue 31).
        ("work-precision", "puma_engage", "scenarios/puma/engage_disengage.pbtxt"),
        # The still rotor's blade-sailing envelope (issue 19): gust peak × direction.
        ("envelope", "puma_gust", "scenarios/puma/gust.pbtxt"),
        # The shipborne engagement's operating-limits envelope (issue 35): wind speed ×
        # relative wind direction on the moving deck, the continuous twin (108 runs).
        ("envelope", "puma_ship", "scenarios/puma/ship_engage_continuous.pbtxt"),
        # The co-simulated impact response under step refinement (issue 16, item 7): the gust's
        # first 6 s (lift-off at ~2.4 s, onto the anti-flap stop at ~3.7 s, back on the droop
        # stop at ~5.0 s and ringing there), error from 3.5 s: both impacts.
        (
            "convergence",
            "puma_gust_impact",
            "scenarios/puma/gust.pbtxt",
            [
                "numerics.end_time=6",
                "study.coarsest_step=0.002",
                "study.halvings=4",
                "study.reference_refinement=2",
                "study.error_from=3.5",
            ],
        ),
        # The SHARCS-like hub (issue 17): the paper's Figs. 9–11 for both blade models, and
        # Fig. 12 over 0.02 s after 0.15 s of settling, at the paper's ρ∞ = 0.95 and damped.
        ("compare", "sharcs_hub", "scenarios/sharcs/hub.pbtxt"),
        (
            "convergence",
            "sharcs_hub",
            "scenarios/sharcs/hub.pbtxt",
            [
                "numerics.end_time=0.27",
                "numerics.smooth.newton_tolerance=1e-10",
                "numerics.smooth.newton_max_iterations=50",
            ],
        ),
        (
            "convergence",
            "sharcs_hub_damped",
            "scenarios/sharcs/hub.pbtxt",
            [
                "numerics.end_time=0.27",
                "numerics.smooth.rho_inf=0.6",
                "numerics.smooth.newton_tolerance=1e-10",
                "numerics.smooth.newton_max_iterations=50",
            ],
        ),
        (
            "convergence",
            "sharcs_hub_structural_damping",
            "scenarios/sharcs/hub.pbtxt",
            [
                "numerics.end_time=0.27",
                "model.elastic_bodies[0].retardation_time=1e-5",
                "numerics.smooth.newton_tolerance=1e-10",
                "numerics.smooth.newton_max_iterations=50",
            ],
        ),
    ]
    for kind, name, path, *entry in plan:
        entry_sets = entry[0] if entry else []  # this entry's own overrides
        out = os.path.join(out_root, f"{kind}-{name}")
        os.makedirs(out, exist_ok=True)
        if reuse and os.path.isfile(os.path.join(out, "report.md")):
            print(f"cosim study: {kind}-{name}: reusing {out}/report.md", file=sys.stderr)
        else:
            STUDIES[kind](runner, os.path.join(ROOT, path), out, list(sets) + entry_sets)
        with open(os.path.join(out, "report.md")) as f:
            text = f.read()
        for png in (p for p in os.listdir(out) if p.endswith(".png")):
            target = f"{kind}-{name}-{png}"
            shutil.copy(os.path.join(out, png), os.path.join(figures, target))
            text = text.replace(f"]({png})", f"](results/{target})")
        if entry_sets:  # the settings that make this entry differ from the scene's own, in its heading
            first, _, rest = text.partition("\n")
            text = f"{first} ({', '.join(entry_sets)})\n{rest}"
        if (kind, name) == ("stability", "scenarios"):
            text = text.replace("# Stability: the hard cases", "# The shipped scenarios, as they run", 1)
        reading = os.path.join(docs, "readings", f"{kind}-{name}.md")
        if os.path.isfile(reading):  # a hand-written reading of the study, kept next to it
            with open(reading) as f:
                text = text.rstrip("\n") + "\n\n" + f.read()
        sections.append(text.replace("\n# ", "\n## ").replace("# ", "## ", 1).rstrip("\n") + "\n\n")
    header = [
        "# Results",
        "",
        "Regenerated by `scripts/cosim study results` (the studies of scripts/study.py on the shipped",
        "scenarios; this machine, 2 cores; about an hour, most of it the Puma runs; `--reuse` keeps reports already made). Next to the papers' numbers where they give them:",
        "",
        "| paper's figure | paper | here | where it is checked |",
        "|---|---|---|---|",
        "| four-bar period (CGα paper, Table 5) | 1.35 s | 1.3514 s | `scenarios/four_bar.pbtxt`, smooth_solver tests |",
        "| CGα order in q, q̇, λ (CGα paper, Section 5) | 2 | 1.98, 2.00, 2.00 at t = 0.5 s (default INDEX2_PROJECTED form; smooth_solver tests), 1.95–1.96 over 2 s (below) | convergence study |",
        "| cantilever tip displacement, 10 kN (CGα paper, Table 2) | Table 2 | within 0.4 % | `scenarios/cantilever_static.pbtxt`, elastic tests |",
        "| co-simulation against entirely nonsmooth, linear oscillator (rotor-sailing paper, Fig. 1) | agree | same error, first order (below) | work-precision study |",
        '| Puma engagement, co-simulated against continuous stops (rotor-sailing paper, Fig. 5) | "good agreement" | flap angle within 0.35° RMS (the droop plane\'s geometry); at full speed coning within 0.0003°, root shear within 1.3 N (below) | compare study |',
        "| Puma engagement against MBDyn on the same rotor (docs/reference/mbdyn-puma.md; issue 33) | — | modelled as MBDyn models it: lift-off 4 ms and re-contact 6 ms apart, peak lag within 0.23° and lead 0.63°, coning 0.052° apart (0.05° asked); MBDyn's inflow correction is the largest difference from the scenes (0.35° of coning) (below) | compare study |",
        '| Puma still rotor in a gust (rotor-sailing paper, Fig. 7) | "correlate well" | blade 1 onto its anti-flap stop and back in both models (a 35 m/s gust, issue 33); flap angle within 0.14° RMS, anti-flap contact 4 ms apart, landing together (below) | compare study |',
        "| Puma engagement (50 s), wall time against MBDyn's 787 s for 52 s (peers.md) | — | co-simulated 73–80 s, 9–10× faster than MBDyn, 1.5–1.6× slower than real time; continuous 13.5 s at h = 2 ms, 3.7× faster than real time (issue 31; below) | timing study, `rotor_benchmark` |",
        "| SHARCS-like hub, blade tip position under step refinement (CGα paper, Fig. 12) | 2 | radial and in-plane 2.2–2.4; flapwise to 1e-4 of its deflection, monotonically (~1.3) once the solid's high-frequency modes are damped (below) | convergence study |",
        "| SHARCS-like hub, hex27 against beam blade (issue 17) | — | flap 0.08° RMS apart, radial root force 33 N RMS of 11.1 kN (below) | compare study |",
        "| Puma gust, co-simulated impact response as h is refined (issue 16) | — | both impacts of the 35 m/s gust: loads converge at order 1.6, at h = 1 ms the root shear within 2.7 kN of ~8 kN peaks, flap within 0.17° (the bouncing after the landing); h ≤ 0.5 ms for peaks within ~10 % (below) | convergence study |",
        "| Puma blade-sailing envelope, gust peak × direction (issue 19) | — | 24 co-simulated runs in 243 s on one worker; four-fold symmetric to the digits shown; at 25 m/s blade lift 0.63 m, smallest clearance to a plane 2 m below the hub at 45°, not at the paper's 90° (below) | envelope study |",
        "| Puma engagement on a frigate's moving deck in its airwake, operating limits (issue 35) | — | 108 continuous runs in 2899 s on two workers; the lowest tips in the run-down; clearance falls with wind speed everywhere, worst from the starboard beam (90–120°); the tip reaches the tail-boom plane at 40 kt; 7 runs failed numerically at stop landings (below) | envelope study |",
        "",
    ]
    with open(os.path.join(docs, "results.md"), "w") as f:
        f.write("\n".join(header) + "\n" + "".join(sections))
    print(f"cosim study: docs/results.md written", file=sys.stderr)


def study_modes(runner, scenario_path, out, sets):
    """Fan plot: the scenario's MODES analysis (numerics.smooth.analysis = MODES; the speeds are
    numerics.start_time..end_time by step, the spin axis numerics.smooth.modes.axis, set in the
    file or with --set), frequencies against rotor speed with the per-revolution lines, each mode
    coloured by what its shape does most (flap, lag or radial motion of the nodes)."""
    run = {
        "id": "modes",
        "scenario": scenario_path,
        "sets": ["numerics.smooth.analysis=MODES"] + list(sets),
        "out": os.path.join(out, "run"),
    }
    run = runner.run_all([run])[0]
    if run["code"] != 0:
        fail(f"the MODES run failed (exit {run['code']}): {run['message']}", run["code"])
    with open(os.path.join(run["out"], "modes.csv")) as f:
        rows = list(csv.DictReader(f))
    speeds = sorted({float(r["speed"]) for r in rows})
    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    kinds = {"flap": "tab:blue", "lag": "tab:red", "radial": "tab:green", "torsion": "tab:purple"}
    for kind, colour in kinds.items():
        pts = [
            (float(r["speed"]), float(r["frequency"]))
            for r in rows
            if max(kinds, key=lambda k: float(r[k + "_share"])) == kind
        ]
        if pts:
            ax.plot([p[0] for p in pts], [p[1] for p in pts], "o", color=colour, ms=4, label=kind)
    top = max(float(r["frequency"]) for r in rows)
    for n in range(1, 9):
        ax.plot([0, speeds[-1]], [0, n * speeds[-1]], ":", color="grey", lw=0.8)
        if n * speeds[-1] < 1.1 * top:
            ax.annotate(f"{n}/rev", (speeds[-1], n * speeds[-1]), fontsize=7, color="grey")
    ax.set_ylim(0, 1.1 * top)
    ax.set_xlabel("rotor speed Ω [rad/s]")
    ax.set_ylabel("frequency [rad/s]")
    ax.set_title(f"fan plot: {os.path.basename(scenario_path)}")
    ax.legend()
    ax.grid(alpha=0.3)
    fig.savefig(os.path.join(out, "fan_plot.png"), dpi=120, bbox_inches="tight")
    plt.close(fig)
    with open(os.path.join(out, "report.md"), "w") as f:
        f.write(f"# Fan plot: {os.path.basename(scenario_path)}\n\n![fan plot](fan_plot.png)\n\n")
        f.write(
            "| Ω [rad/s] | mode | ω [rad/s] | per rev | ζ | flap | lag | radial | torsion |\n"
            "|---|---|---|---|---|---|---|---|---|\n"
        )
        for r in rows:
            f.write(
                f"| {float(r['speed']):.4g} | {r['mode']} | {float(r['frequency']):.5g} | {float(r['per_rev']):.4g} | "
                f"{float(r['damping_ratio']):.3g} | {float(r['flap_share']):.2f} | {float(r['lag_share']):.2f} | "
                f"{float(r['radial_share']):.2f} | {float(r['torsion_share']):.2f} |\n"
            )
    print(f"cosim study: fan plot in {out}/fan_plot.png, table in {out}/report.md", file=sys.stderr)


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


def study_compare(runner, scenario_path, out, sets):
    """Runs of one scene drawn on the same axes (study.compare: e.g. co-simulated and continuous
    contact), their differences (RMS and peak, against the first run on its output times) and each
    stop contact (study.compare[].contact_probes): start, end, the peaks of study.probes in it."""
    scenario, study, sets = with_study_sets(runner, scenario_path, sets)
    specs = study.get("compare", [])
    if len(specs) < 2:
        fail(f"{scenario_path}: study compare needs two or more `study {{ compare {{ ... }} }}` runs, got {len(specs)}")
    probes = list(study.get("probes", []))
    if not probes:
        fail(f"{scenario_path}: study compare needs `study {{ probes: [...] }}`, the probes drawn")
    for k, m in enumerate(study.get("measures", [])):
        where = f"{scenario_path}: study.measures[{k}]"
        if not m.get("probe"):
            fail(f"{where}.probe: missing; name the probe measured")
        if m.get("kind") not in ("MEAN", "MAX", "MIN", "LAST_NEAR_START", "FIRST_NEAR_START"):
            fail(f"{where}.kind: missing; give MEAN, MAX, MIN, LAST_NEAR_START or FIRST_NEAR_START")
        if m["kind"].endswith("NEAR_START") and not float(m.get("tolerance", 0.0)) > 0.0:
            fail(f"{where}.tolerance: {m.get('tolerance', 'missing')}; {m['kind']} needs a positive tolerance")
    runs, recorded = [], {}
    for i, spec in enumerate(specs):
        run = {
            "id": spec.get("name", f"run{i}"),
            "sets": list(sets) + list(spec.get("set", [])),
            "contact_probes": list(spec.get("contact_probes", [])),
            "out": os.path.join(out, "runs", f"r{i}"),
        }
        if spec.get("history_file"):  # another code's recorded history: read, not run
            recorded[i] = recorded_history(scenario_path, spec, i)
            run.update(
                {
                    "scenario": spec["history_file"],
                    "code": 0,
                    "wall": float("nan"),
                    "seconds": float("nan"),
                    "summary": None,
                    "message": "",
                    "recorded": True,
                }
            )
        else:
            run["scenario"] = compare_run_scenario(scenario_path, spec, i)
            run["settle"] = bool(spec.get("settle_statically"))
        runs.append(run)
    to_run = [r for r in runs if not r.get("recorded")]
    settle_statically(runner, [r for r in to_run if r["settle"]], out)
    runner.run_all([r for r in to_run if r.get("code") is None])
    histories = [recorded[i] if i in recorded else read_histories(r["out"]) for i, r in enumerate(runs)]
    for r, h in zip(runs, histories):
        missing = [p for p in probes + r["contact_probes"] if p not in h]
        if missing and r["code"] == 0:
            fail(
                f"run '{r['id']}' has no probe(s) {', '.join(missing)} (its history has {', '.join(sorted(h)) or 'none'})"
            )
    # Differences against the first run, on its output times within the common span.
    ref_hist = histories[0]
    diff_rows = []
    for r, h in zip(runs[1:], histories[1:]):
        for p in probes:
            if p not in ref_hist or p not in h:
                continue
            t0, v0 = ref_hist[p]
            t1, v1 = h[p]
            inside = (t0 >= max(t0[0], t1[0])) & (t0 <= min(t0[-1], t1[-1]))
            if not inside.any():
                continue
            d = np.interp(t0[inside], t1, v1) - v0[inside]
            k = int(np.argmax(np.abs(d)))
            diff_rows.append(
                [
                    r["id"],
                    p,
                    float(np.sqrt(np.mean(d * d))),
                    float(abs(d[k])),
                    float(t0[inside][k]),
                    float(np.max(np.abs(v0[inside]))),
                ]
            )
    # Contacts.
    contact_rows = []
    for r, h in zip(runs, histories):
        for cp in r["contact_probes"]:
            if cp not in h:
                continue
            t, v = h[cp]
            for n, (a, b, i0, i1) in enumerate(contact_episodes(t, v)):
                row = [r["id"], cp, n + 1, float(a), float(b), float(np.max(np.abs(v[i0 : i1 + 1])))]
                for p in probes:
                    if p in h:
                        tp, vp = h[p]
                        window = (tp >= a) & (tp <= b)
                        row.append(float(np.max(np.abs(vp[window]))) if window.any() else float("nan"))
                    else:
                        row.append(float("nan"))
                contact_rows.append(row)
    measure_rows = [
        [m.get("name", m.get("probe", "?"))] + [compare_measure(h, m) for h in histories]
        for m in study.get("measures", [])
    ]
    write_csv(
        os.path.join(out, "differences.csv"), ["run", "probe", "rms", "peak", "peak_time", "reference_peak"], diff_rows
    )
    if measure_rows:
        write_csv(os.path.join(out, "measures.csv"), ["measure"] + [r["id"] for r in runs], measure_rows)
    write_csv(
        os.path.join(out, "contacts.csv"),
        ["run", "contact_probe", "contact", "start", "end", "peak_contact"] + [f"peak_{p}" for p in probes],
        contact_rows,
    )
    write_csv(
        os.path.join(out, "runs.csv"),
        ["run", "exit", "wall_time", "process_seconds", "steps", "coupling_iterations_per_step"],
        [
            [
                r["id"],
                r["code"],
                r["wall"],
                r["seconds"],
                (r["summary"] or {}).get("steps", ""),
                ((r["summary"] or {}).get("coupling_iterations") or {}).get("mean_per_step", ""),
            ]
            for r in runs
        ],
    )
    # The figure: one axis per probe, every run on it.
    fig, axes = plt.subplots(len(probes), 1, figsize=(7.5, 2.1 * len(probes)), sharex=True)
    axes = np.atleast_1d(axes)
    styles = ["-", "--", ":", "-."]
    for ax, p in zip(axes, probes):
        for i, (r, h) in enumerate(zip(runs, histories)):
            if p in h:
                ax.plot(h[p][0], h[p][1], styles[i % len(styles)], lw=1.0, label=r["id"])
        ax.set_ylabel(p, fontsize=8)
    axes[-1].set_xlabel("time [s]")
    title = " against ".join(r["id"] for r in runs) if len(runs) <= 3 else f"{len(runs)} runs against '{runs[0]['id']}'"
    axes[0].set_title(f"{scenario['name']}: {title}", fontsize=10)
    save_plot(fig, list(axes), os.path.join(out, "compare.png"))
    lines = [
        f"# Compared: {scenario['name']}",
        "",
        scenario.get("description", ""),
        "",
        "![compare](compare.png)",
        "",
        "| run | exit | wall time of the steps [s] | process [s] | steps | coupling iterations per step |",
        "|---|---|---|---|---|---|",
    ]
    for r in runs:
        s_ = r["summary"] or {}
        if r.get("recorded"):
            lines.append(f"| {r['id']} | recorded: {r['scenario']} | — | — | — | — |")
            continue
        lines.append(
            f"| {r['id']} | {r['code']} | {r['wall']:.1f} | {r['seconds']:.1f} | {s_.get('steps', '—')} | "
            f"{fmt((s_.get('coupling_iterations') or {}).get('mean_per_step', float('nan')))} |"
        )
    lines += measures_table(runs, study.get("measures", []), measure_rows)
    lines += [
        "",
        f"Differences from '{runs[0]['id']}' on its output times (RMS, largest and when; the reference's largest |value| for scale):",
        "",
        "| run | probe | RMS | peak | at [s] | reference peak |",
        "|---|---|---|---|---|---|",
    ]
    for row in diff_rows:
        lines.append(f"| {row[0]} | {row[1]} | {fmt(row[2])} | {fmt(row[3])} | {row[4]:.3f} | {fmt(row[5])} |")
    if any(r["contact_probes"] for r in runs):  # scenes without stops have no contact table
        lines += [
            "",
            "Stop contacts (samples where the contact probe is non-zero; the peaks of each probe within):",
            "",
            "| run | contact probe | # | start [s] | end [s] | peak contact | "
            + " | ".join(f"peak {p}" for p in probes)
            + " |",
            "|---|---|---|---|---|---|" + "---|" * len(probes),
        ]
    shown = {}
    for row in contact_rows:
        key = (row[0], row[1])
        shown[key] = shown.get(key, 0) + 1
        if shown[key] <= 12:
            lines.append(
                "| "
                + " | ".join(
                    [row[0], row[1], str(row[2]), f"{row[3]:.3f}", f"{row[4]:.3f}"] + [fmt(x) for x in row[5:]]
                )
                + " |"
            )
    for key, n in shown.items():
        if n > 12:
            lines.append(f"| {key[0]} | {key[1]} | … {n - 12} more in contacts.csv | | | | " + " | " * len(probes))
    lines += ["", failures_section(runs)]
    write_report(out, lines)
    return {"runs": runs, "differences": diff_rows, "contacts": contact_rows}


def recorded_history(scenario_path, spec, i):
    """study.compare[i].history_file: a CSV of another code's run (a `time` column, then one per
    probe) as {probe: (times, values)}; refused (exit 2) naming the place if unreadable."""
    path = os.path.join(os.path.dirname(scenario_path), spec["history_file"])
    where = f"{scenario_path}: study.compare[{i}].history_file"
    if not os.path.isfile(path):
        fail(f"{where}: no such file: {path}")
    try:
        table = history_table(path)
    except ValueError as e:
        fail(f"{where}: {path} is not a CSV table: {e}")
    if not table:
        fail(f"{where}: {path} needs a header with a `time` column first, one column per probe, and rows")
    return table


def settle_statically(runner, runs, out):
    """study.compare[].settle_statically: each run's scene solved STATIC over one step first (the
    loads and drives at start_time + step), the run then starting at that time from its state."""
    if not runs:
        return
    statics = []
    for r in runs:
        numerics = runner.scenario_json(r["scenario"], r["sets"]).get("numerics", {})
        t1 = float(numerics.get("start_time", 0.0)) + float(numerics["step"])
        r["settled_at"] = t1
        statics.append(
            {
                "id": f"{r['id']}: static equilibrium at t = {t1:g} s",
                "scenario": r["scenario"],
                "sets": r["sets"] + ["numerics.smooth.analysis=STATIC", f"numerics.end_time={t1!r}"],
                "out": r["out"] + "-static",
            }
        )
    for r, st in zip(runs, runner.run_all(statics)):
        state = os.path.abspath(os.path.join(st["out"], "final_state.pb"))
        if st["code"] != 0 or not os.path.isfile(state):
            # The run is reported failed with the static step's reason; it is not started.
            r.update(
                {
                    "code": st["code"] or 3,
                    "wall": float("nan"),
                    "seconds": float("nan"),
                    "summary": st["summary"],
                    "message": f"its static equilibrium failed: {st['message']}",
                }
            )
            continue
        r["sets"] = r["sets"] + start_from(state, r["settled_at"])


def compare_measure(history, m):
    """One study.measures entry on one run's history (nan where the probe or the event is absent)."""
    if m.get("probe") not in history:
        return float("nan")
    t, v = history[m["probe"]]
    window = (t >= float(m.get("from", -np.inf))) & (t <= float(m.get("to", np.inf)))
    if not window.any():
        return float("nan")
    kind = m["kind"]  # checked by study_compare
    if kind == "MEAN":
        return float(np.mean(v[window]))
    if kind == "MAX":
        return float(np.max(v[window]))
    if kind == "MIN":
        return float(np.min(v[window]))
    near = window & (np.abs(v - v[0]) <= float(m.get("tolerance", 0.0)))
    if not near.any():
        return float("nan")
    return float(t[near][-1] if kind == "LAST_NEAR_START" else t[near][0])


def measures_table(runs, measures, rows):
    """The report's table of study.measures: each run's value, and for the runs after the first
    the difference from the first's, marked where it is within the measure's `agreement`."""
    if not rows:
        return []
    lines = [
        "",
        f"Measures (differences from '{runs[0]['id']}'; ✓ within the agreement asked, ✗ not):",
        "",
        "| measure | " + " | ".join(r["id"] for r in runs) + " | agreement |",
        "|---|" + "---|" * (len(runs) + 1),
    ]
    for m, row in zip(measures, rows):
        cells, ref = [row[0], f"{row[1]:.5g}"], row[1]
        for x in row[2:]:
            d = x - ref
            mark = "" if "agreement" not in m or d != d else (" ✓" if abs(d) <= float(m["agreement"]) else " ✗")
            cells.append("—" if x != x else f"{x:.5g} ({d:+.3g}{mark})")
        cells.append(f"{float(m['agreement']):g}" if "agreement" in m else "—")
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def study_timing(runner, scenario_path, out, sets):
    """Wall time of a scene's runs (study.compare, else the scene itself), each with its output as
    written and without (a history row only at the first and last step), one run at a time so
    that they do not share the cores; per simulated second, and as a ratio to study.peer."""
    scenario, study, sets = with_study_sets(runner, scenario_path, sets)
    specs = study.get("compare") or [{"name": scenario["name"]}]
    peer = study_peer(scenario_path, study)
    runs = []
    for i, spec in enumerate(specs):
        path = compare_run_scenario(scenario_path, spec, i)
        for output in ("as written", "none"):
            extra = [] if output == "as written" else ["output.every=1000000000"]
            runs.append(
                {
                    "id": f"{spec.get('name', f'run{i}')}: output {output}",
                    "name": spec.get("name", f"run{i}"),
                    "output": output,
                    "scenario": path,
                    "sets": list(sets) + list(spec.get("set", [])) + extra,
                    "out": os.path.join(out, "runs", f"r{i}_{'out' if output == 'as written' else 'none'}"),
                }
            )
    jobs, runner.jobs = runner.jobs, 1  # timings: alone on the machine (as far as this study goes)
    try:
        for r in runs:
            r["load_before"] = os.getloadavg()[0]
            runner.run_all([r])
    finally:
        runner.jobs = jobs
    rows = []
    for r in runs:
        s_ = r["summary"] or {}
        simulated = s_.get("simulated_time", float("nan"))
        per_second = r["wall"] / simulated if simulated and simulated == simulated else float("nan")
        ratio = (peer["wall_time"] / peer["simulated_time"]) / per_second if peer and per_second > 0 else float("nan")
        rows.append(
            [
                r["id"],
                r["code"],
                s_.get("steps", ""),
                simulated,
                r["wall"],
                r["seconds"],
                per_second,
                ratio,
                (s_.get("coupling_iterations") or {}).get("mean_per_step", float("nan")),
                (s_.get("newton_iterations") or {}).get("mean_per_step", float("nan")),
                (s_.get("counters") or {}).get("newton_factorizations", ""),
                r["load_before"],
            ]
        )
    header = [
        "run",
        "exit",
        "steps",
        "simulated_time",
        "step_wall_time",
        "process_seconds",
        "wall_per_simulated_second",
        "speed_ratio_to_peer",
        "coupling_iterations_per_step",
        "newton_iterations_per_step",
        "newton_factorizations",
        "load_average_before",
    ]
    write_csv(os.path.join(out, "timing.csv"), header, rows)
    lines = [
        f"# Timing: {scenario['name']}",
        "",
        scenario.get("description", ""),
        "",
        "Each run alone (one at a time), with its output as written and without (`output.every` = 1e9: "
        "a history row at the first and last step only). Wall time of the time steps (the step loop; "
        "the process's includes start-up, the initial conditions and the last writes).",
        "",
    ]
    if peer:
        lines += [
            f"Peer: {peer.get('name', 'peer')}: {peer['wall_time']:g} s of wall time for {peer['simulated_time']:g} s "
            f"simulated ({peer['wall_time'] / peer['simulated_time']:.3g} s per simulated second; "
            f"{peer.get('source', 'source not given')}). Ratio = the peer's wall time per simulated second "
            "over this run's (> 1: this run is faster).",
            "",
        ]
    lines += [
        "| run | exit | steps | simulated [s] | steps' wall [s] | process [s] | wall per simulated s | "
        "× faster than the peer | coupling its/step | Newton its/step | factorisations | 1-min load as it began |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for row in rows:
        lines.append(
            "| "
            + " | ".join(
                [
                    row[0],
                    str(row[1]),
                    str(row[2]),
                    fmt(row[3]),
                    fmt(row[4]),
                    fmt(row[5]),
                    fmt(row[6]),
                    fmt(row[7]),
                    fmt(row[8]),
                    fmt(row[9]),
                    str(row[10]),
                    f"{row[11]:.2f}",
                ]
            )
            + " |"
        )
    lines += [
        "",
        "Real time means a wall time per simulated second of 1 or less. The load average as a run began "
        "still counts the previous run's processes (it decays over a minute): a figure well above the "
        "previous run's process count means something else was running.",
        "",
        failures_section(runs),
    ]
    write_report(out, lines)
    return {"runs": runs, "rows": rows}


# ---------------------------------------------------------------------------------------------
# Envelope
# ---------------------------------------------------------------------------------------------


def axis_sets(axis, value, where):
    """The overrides of one envelope axis at `value`: each {expression} of v evaluated."""

    def evaluate(match):
        expression = match.group(1)
        try:
            result = eval(compile(expression, where, "eval"), {"__builtins__": {}}, dict(SAFE_MATH, v=float(value)))
            return repr(float(result))
        except Exception as e:  # noqa: BLE001 - the user's expression
            fail(f"{where}: '{{{expression}}}' at v = {value:g} fails: {e}")

    out = []
    for j, template in enumerate(axis.get("set", [])):
        if "=" not in template:
            fail(f"{where}.set[{j}]: '{template}' is not FIELD.PATH=VALUE")
        out.append(re.sub(r"\{([^{}]*)\}", evaluate, template))
    return out


def envelope_point(history, spec, step):
    """The envelope's measures of one run from its history (what exists of it for a failed run),
    over t >= spec.from_time."""
    start = float(spec.get("from_time", 0.0))
    history = {p: (t[t >= start], v[t >= start]) for p, (t, v) in history.items()}
    m = {}
    lowest = highest = (float("nan"), "", float("nan"))
    down = up = (float("nan"), "")
    for p in spec.get("tip_probes", []):
        if p not in history or len(history[p][0]) == 0:
            continue
        t, z = history[p]
        i, k = int(np.argmin(z)), int(np.argmax(z))
        if not z[i] >= lowest[0]:
            lowest = (float(z[i]), p, float(t[i]))
        if not z[k] <= highest[0]:
            highest = (float(z[k]), p, float(t[k]))
        if not z[0] - z[i] <= down[0]:
            down = (float(z[0] - z[i]), p)
        if not z[k] - z[0] <= up[0]:
            up = (float(z[k] - z[0]), p)
    m["tip_lowest"], m["tip_lowest_probe"], m["tip_lowest_time"] = lowest
    m["tip_highest"], m["tip_highest_probe"], m["tip_highest_time"] = highest
    m["tip_down"], m["tip_down_probe"] = down
    m["tip_up"], m["tip_up_probe"] = up
    height = spec.get("clearance_height")
    m["clearance"] = lowest[0] - height if height is not None else float("nan")
    peak, peak_probe, impacts = 0.0, "", 0
    found = False
    for kind in ("impulse_probes", "force_probes"):
        for p in spec.get(kind, []):
            if p not in history:
                continue
            found = True
            t, v = history[p]
            force = np.abs(v) / step if kind == "impulse_probes" else np.abs(v)
            if len(force) and force.max() > peak:
                peak, peak_probe = float(force.max()), p
            impacts += len(contact_episodes(t, v))
    m["peak_stop_force"] = peak if found else float("nan")
    m["peak_stop_force_probe"] = peak_probe
    m["impacts"] = impacts if found else float("nan")
    return m


# envelope_point's measures, in runs.csv's order.
ENVELOPE_COLUMNS = [
    "tip_lowest",
    "tip_lowest_probe",
    "tip_lowest_time",
    "tip_highest",
    "tip_highest_probe",
    "tip_highest_time",
    "tip_down",
    "tip_up",
    "clearance",
    "peak_stop_force",
    "peak_stop_force_probe",
    "impacts",
]
ENVELOPE_MEASURES = [
    ("tip_lowest", "lowest tip [m]"),
    ("tip_highest", "highest tip [m]"),
    ("clearance", "smallest clearance [m]"),
    ("peak_stop_force", "peak stop force"),
    ("impacts", "stop impacts"),
]


def study_envelope(runner, scenario_path, out, sets):
    """The scene over a grid of one or two named quantities (study.envelope.axes), each point a
    full run; per point the tips' extremes, the clearance to a plane, the stops' peak force and
    impacts. Failed runs are points too (their measures up to where they stopped, marked)."""
    started = time.time()
    scenario, study, sets = with_study_sets(runner, scenario_path, sets)
    spec = study.get("envelope")
    where = f"{scenario_path}: study.envelope"
    if not spec:
        fail(f"{scenario_path}: study envelope needs `study {{ envelope {{ axes {{ ... }} tip_probes: [...] }} }}`")
    axes = spec.get("axes", [])
    if not 1 <= len(axes) <= 2:
        fail(f"{where}.axes: {len(axes)} axes; expected one or two")
    for a, axis in enumerate(axes):
        if not axis.get("values") or not axis.get("set"):
            fail(f"{where}.axes[{a}] ('{axis.get('name', '')}'): needs values and set")
    if not spec.get("tip_probes") and not spec.get("impulse_probes") and not spec.get("force_probes"):
        fail(f"{where}: nothing to measure: give tip_probes, impulse_probes or force_probes")
    sets = list(sets) + list(spec.get("set", []))
    if spec.get("impulse_probes"):
        sets.append("output.every=1")  # every step's impulse: none missed between rows
    # study.restart_time: every point starts from one run's state there (co-simulated scenes
    # too: each contact process's state travels with the smooth solver's); the axes' overrides
    # must not act before that time (a gust that has not reached the rotor).
    restart_sets, restart_note = settled_start(
        runner, scenario_path, study, sets, out, "the measures are the window's, without the start-up"
    )
    sets += restart_sets
    names = [a.get("name") or f"axis{i}" for i, a in enumerate(axes)]
    grid = [[v] for v in axes[0]["values"]]
    if len(axes) == 2:
        grid = [[v0, v1] for v0 in axes[0]["values"] for v1 in axes[1]["values"]]
    runs = []
    for i, point in enumerate(grid):
        point_sets = [s_ for a, v in zip(axes, point) for s_ in axis_sets(a, v, f"{where}.axes[{axes.index(a)}]")]
        label = ", ".join(f"{n} = {v:g}" for n, v in zip(names, point))
        runs.append(
            {
                "id": label,
                "point": point,
                "scenario": scenario_path,
                "sets": sets + point_sets,
                "out": os.path.join(out, "runs", f"p{i}"),
            }
        )
    # Every override checked before any run: a bad field path is the study's input error.
    runner.scenario_json(scenario_path, runs[0]["sets"])
    runs = runner.run_all(runs)
    rows = []
    for r in runs:
        summary = r["summary"] or {}
        step = (summary.get("numerics") or {}).get("step") or scenario["numerics"].get("step", 1.0)
        m = envelope_point(read_histories(r["out"]), spec, float(step))
        r["measures"] = m
        rows.append(
            list(r["point"])
            + [r["code"], r["wall"], summary.get("simulated_time", float("nan")), r.get("host", "")]
            + [m[k] for k in ENVELOPE_COLUMNS]
        )
    write_csv(
        os.path.join(out, "runs.csv"), names + ["exit", "wall_time", "simulated_time", "host"] + ENVELOPE_COLUMNS, rows
    )
    measures = [(k, label) for k, label in ENVELOPE_MEASURES if any(np.isfinite(r["measures"][k]) for r in runs)]
    plot_envelope(runs, axes, names, measures, os.path.join(out, "envelope.png"), scenario["name"])
    limits_note = plot_operating_limits(
        runs, axes, names, spec, os.path.join(out, "operating_limits.png"), scenario["name"]
    )
    elapsed = time.time() - started
    cpu = sum(r["seconds"] for r in runs if r["seconds"] == r["seconds"])
    lines = (
        [
            f"# Envelope: {scenario['name']}",
            "",
            scenario.get("description", ""),
            "",
            f"{len(runs)} runs over "
            + " × ".join(f"{n} ({len(a['values'])} values)" for n, a in zip(names, axes))
            + (
                f"; the study took {elapsed:.0f} s on {runner.cluster().workers()} Dask workers "
                f"({'scheduler ' + runner.scheduler if runner.scheduler else 'local cluster'}), the runs {cpu:.0f} s "
                f"one after the other (processes' wall time)."
                if any(r.get("host") != "kept" for r in runs)
                else f"; every run kept from an earlier study (--reuse): the runs took {cpu:.0f} s one after the other."
            ),
            "",
            "![envelope](envelope.png)",
            "",
        ]
        + ([restart_note, ""] if restart_note else [])
        + (["![operating limits](operating_limits.png)", "", limits_note, ""] if limits_note else [])
        + [
            "Tip heights are the tip probes' values (lowest and highest over the run and the probes, e.g. the "
            "blades; down/up: the largest excursion from a tip's height at the start"
            + (f", measured from t = {spec['from_time']:g} s on" if spec.get("from_time") else "")
            + ")"
            + (f"; clearance above the plane at {spec['clearance_height']:g} m" if "clearance_height" in spec else "")
            + "; stop force: "
            + (
                "a step's impulse over the step (impulse probes)"
                if spec.get("impulse_probes")
                else "the force probes as they are"
            )
            + "; impacts: runs of non-zero contact samples.",
            "",
            "| " + " | ".join(names) + " | exit | lowest tip [m] (probe, t [s]) | highest tip [m] | down / up [m] | "
            "clearance [m] | peak stop force | impacts | wall [s] |",
            "|" + "---|" * (len(names) + 8),
        ]
    )
    for r in runs:
        m = r["measures"]
        exit_text = (
            "0"
            if r["code"] == 0
            else f"**{r['code']}** (t = {fmt((r['summary'] or {}).get('simulated_time', float('nan')))} s)"
        )
        lines.append(
            "| " + " | ".join(f"{v:g}" for v in r["point"]) + f" | {exit_text} | {fmt(m['tip_lowest'])} "
            f"({m['tip_lowest_probe']}, {fmt(m['tip_lowest_time'])}) | {fmt(m['tip_highest'])} | "
            f"{fmt(m['tip_down'])} / {fmt(m['tip_up'])} | {fmt(m['clearance'])} | {fmt(m['peak_stop_force'])} | "
            f"{fmt(m['impacts'])} | {r['wall']:.1f} |"
        )
    ok = [r for r in runs if r["code"] == 0]
    if ok:
        lines += ["", "Worst points (completed runs):", ""]
        for key, label, worst in (
            ("tip_lowest", "lowest tip", min),
            ("clearance", "smallest clearance", min),
            ("peak_stop_force", "largest stop force", max),
            ("impacts", "most impacts", max),
        ):
            finite = [r for r in ok if np.isfinite(r["measures"][key])]
            if finite:
                r = worst(finite, key=lambda x: x["measures"][key])
                lines.append(f"- {label}: {fmt(r['measures'][key])} at {r['id']}")
    lines += ["", failures_section(runs)]
    write_report(out, lines)
    return {"runs": runs}


def plot_envelope(runs, axes, names, measures, path, title):
    """One panel per measure: against the axis (one axis), a polar map (second axis in degrees),
    or a coloured grid (two axes); failed runs marked with a cross."""
    if not measures:
        return
    polar = len(axes) == 2 and axes[1].get("unit") == "deg"
    fig = plt.figure(figsize=(4.2 * min(len(measures), 3), 3.8 * ((len(measures) + 2) // 3)))
    for n, (key, label) in enumerate(measures):
        ax = fig.add_subplot(
            (len(measures) + 2) // 3, min(len(measures), 3), n + 1, projection="polar" if polar else None
        )
        values = np.array([r["measures"][key] for r in runs], dtype=float)
        failed = np.array([r["code"] != 0 for r in runs])
        if len(axes) == 1:
            x = np.array([r["point"][0] for r in runs])
            order = np.argsort(x)
            ax.plot(x[order], values[order], "o-")
            ax.plot(x[failed], values[failed], "rx", ms=9, label="failed run")
            ax.set_xlabel(f"{names[0]} [{axes[0].get('unit', '')}]")
            ax.set_ylabel(label)
        else:
            a0 = np.array([r["point"][0] for r in runs])
            a1 = np.array([r["point"][1] for r in runs])
            if polar:
                if axes[1].get("compass"):
                    ax.set_theta_zero_location("N")
                    ax.set_theta_direction(-1)
                theta, radius = np.radians(a1), a0
                sc = ax.scatter(theta, radius, c=values, s=140, cmap="viridis", edgecolors="k")
                ax.set_rlabel_position(90)
                ax.set_title(
                    f"{label}\n(angle: {names[1]}, radius: {names[0]} [{axes[0].get('unit', '')}])", fontsize=8
                )
            else:
                sc = ax.scatter(a1, a0, c=values, s=160, marker="s", cmap="viridis", edgecolors="k")
                for values_of, scale in ((a1, ax.set_xscale), (a0, ax.set_yscale)):
                    if values_of.min() > 0 and values_of.max() >= 50 * values_of.min():
                        scale("log")  # values over decades (a stiffness, a step)
                ax.set_xlabel(f"{names[1]} [{axes[1].get('unit', '')}]")
                ax.set_ylabel(f"{names[0]} [{axes[0].get('unit', '')}]")
                ax.set_title(label, fontsize=9)
            ax.scatter((np.radians(a1) if polar else a1)[failed], a0[failed], marker="x", c="r", s=90)
            for th, rr, v in zip(np.radians(a1) if polar else a1, a0, values):
                if np.isfinite(v):
                    ax.annotate(
                        f"{v:.3g}",
                        (th, rr),
                        fontsize=6,
                        ha="center",
                        va="bottom",
                        xytext=(0, 7),
                        textcoords="offset points",
                    )
            fig.colorbar(sc, ax=ax, shrink=0.7)
    fig.suptitle(f"{title}: envelope (red crosses: failed runs)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def unsafe_points(runs, threshold):
    """Per run: True where the clearance is below `threshold` or the run failed (a failed run is
    not counted safe), False where it completed above it, None without a clearance."""
    flags = []
    for r in runs:
        c = r["measures"]["clearance"]
        if r["code"] != 0:
            flags.append(True)
        elif np.isfinite(c):
            flags.append(bool(c < threshold))
        else:
            flags.append(None)
    return flags


def plot_operating_limits(runs, axes, names, spec, path, title):
    """The operating-limits diagram: wind speed radial, direction around (clockwise from the top
    for a `compass` axis), each point's sector coloured by its clearance and hatched red where it
    is unsafe (clearance below spec.unsafe_clearance, or a failed run). Returns the report's
    sentence on it, or "" when the study has no such threshold."""
    threshold = spec.get("unsafe_clearance")
    if threshold is None or len(axes) != 2 or axes[1].get("unit") != "deg":
        return ""
    speeds, directions = sorted(set(axes[0]["values"])), sorted(set(axes[1]["values"]))

    def edges(values, lo=None):
        mids = [(a + b) / 2 for a, b in zip(values, values[1:])]
        first = values[0] - (mids[0] - values[0] if mids else 0.5)
        last = values[-1] + (values[-1] - mids[-1] if mids else 0.5)
        return [max(first, lo) if lo is not None else first] + mids + [last]

    r_edges = edges(speeds, 0.0)
    step = (directions[1] - directions[0]) if len(directions) > 1 else 360.0
    flags = unsafe_points(runs, float(threshold))
    clearances = np.array([r["measures"]["clearance"] for r in runs], dtype=float)
    finite = clearances[np.isfinite(clearances)]
    norm = plt.Normalize(finite.min(), finite.max()) if len(finite) else plt.Normalize(0, 1)
    cmap = plt.get_cmap("viridis")
    fig = plt.figure(figsize=(6.4, 6.0))
    ax = fig.add_subplot(projection="polar")
    if axes[1].get("compass"):
        ax.set_theta_zero_location("N")
        ax.set_theta_direction(-1)
    for r, unsafe, c in zip(runs, flags, clearances):
        speed, direction = r["point"]
        i = speeds.index(speed)
        # The point's cell: its direction's sector between its speed's ring edges.
        cell = dict(
            x=np.radians(direction), height=r_edges[i + 1] - r_edges[i], width=np.radians(step), bottom=r_edges[i]
        )
        colour = cmap(norm(c)) if np.isfinite(c) else (0.85, 0.85, 0.85, 1)
        ax.bar(**cell, color=colour, edgecolor="white", linewidth=0.5)
        if unsafe:
            ax.bar(**cell, fill=False, hatch="///", edgecolor="red", linewidth=0.0)
        if r["code"] != 0:
            ax.plot(np.radians(direction), speed, "rx", ms=8, mew=2)
    # The boundary: per direction, the lowest unsafe speed's inner edge.
    boundary = []
    for d in directions:
        at = [(r["point"][0], f) for r, f in zip(runs, flags) if r["point"][1] == d and f]
        boundary.append(r_edges[speeds.index(min(at)[0])] if at else r_edges[-1])
    theta = np.radians(directions + [directions[0] + 360])
    ax.plot(theta, boundary + boundary[:1], "r-", lw=2, drawstyle="steps-mid")
    ax.set_rlim(0, r_edges[-1])
    ax.set_rlabel_position(135)
    sm = plt.cm.ScalarMappable(norm=norm, cmap=cmap)
    fig.colorbar(sm, ax=ax, shrink=0.7, label="smallest tip clearance [m]")
    ax.set_title(
        f"{title}: operating limits\nradial: {names[0]} [{axes[0].get('unit', '')}]; around: {names[1]}\n"
        f"hatched: clearance < {threshold:g} m or a failed run (x)",
        fontsize=9,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    n_unsafe = sum(1 for f in flags if f)
    failed = sum(1 for r in runs if r["code"] != 0)
    return (
        f"Operating limits: {n_unsafe} of {len(runs)} points unsafe (clearance below {threshold:g} m"
        + (f", or one of the {failed} failed runs" if failed else "")
        + "); the red line bounds the safe region "
        "from inside (per direction, the lowest unsafe wind speed's cell)."
    )


STUDIES = {
    "convergence": study_convergence,
    "work-precision": study_work_precision,
    "coupling": study_coupling,
    "stability": study_stability,
    "modes": study_modes,
    "compare": study_compare,
    "timing": study_timing,
    "envelope": study_envelope,
}


def main():
    parser = argparse.ArgumentParser(
        prog="scripts/cosim study", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("kind", choices=list(STUDIES) + ["results"])
    parser.add_argument("scenario", nargs="?", help="a scenario file (a folder for stability)")
    parser.add_argument("--out", help="output folder (default runs/study/KIND-NAME)")
    parser.add_argument(
        "--jobs",
        type=int,
        default=os.cpu_count() or 1,
        help="workers of the local Dask cluster: runs at once (default: cores)",
    )
    parser.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="send the runs to the Dask scheduler at ADDRESS (e.g. tcp://host:8786) instead of a "
        "local cluster; its workers need the project built at the same path (or COSIM_BIN_DIR)",
    )
    parser.add_argument(
        "--set", action="append", default=[], metavar="FIELD.PATH=VALUE", help="override applied to every run"
    )
    parser.add_argument(
        "--reuse",
        action="store_true",
        help="keep runs already in the output folder with the same scenario and overrides (resume an "
        "interrupted study); results: keep a study's report already made",
    )
    parser.add_argument("--bin", default=os.environ.get("COSIM_BIN_DIR", os.path.join(ROOT, "build", "release", "bin")))
    args = parser.parse_args()
    if args.jobs < 1:
        fail(f"--jobs {args.jobs}: expected a positive number of workers")
    runner = Runner(args.bin, args.jobs, args.scheduler, args.reuse)
    try:
        if args.kind == "results":
            results(runner, args.out or os.path.join(ROOT, "runs", "study", "results"), args.set, args.reuse)
            return
        if not args.scenario:
            fail(f"study {args.kind} needs a scenario")
        if not os.path.exists(args.scenario):
            fail(f"{args.scenario}: no such file or folder")
        name = os.path.splitext(os.path.basename(os.path.normpath(args.scenario)))[0]
        out = args.out or os.path.join(ROOT, "runs", "study", f"{args.kind}-{name}")
        os.makedirs(out, exist_ok=True)
        STUDIES[args.kind](runner, os.path.abspath(args.scenario), out, args.set)
    finally:
        runner.close()


if __name__ == "__main__":
    main()
