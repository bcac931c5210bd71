"""The work-precision study: error against wall time for each method (study.methods), with the
errors of contact events where the scene has stops."""
import json
import os

import numpy as np
import matplotlib

from studies.common import (
    report_head,
    Reference,
    contact_episodes,
    default_methods,
    every_for,
    fail,
    failures_section,
    fmt,
    halving_steps,
    probe_error,
    read_histories,
    Run,
    run_and_measure,
    run_scenario,
    save_plot,
    study_peer,
    with_study_sets,
    write_csv,
    write_report,
)

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402 - after matplotlib.use("Agg") (no display)


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
    references, reference_of = plan_references(scenario_path, study, methods, sets, out)
    done = runner.run_all(references + runs)  # (the references first: a study cut short can be resumed with --reuse)
    references, runs = done[: len(references)], done[len(references) :]
    for r in references:
        if r.code != 0:
            fail(f"the work-precision reference run '{r.id}' failed (exit {r.code}): {r.message}", 3)
    measures = (
        [f"history {p}" for p in events.get("history_probes", [])]
        + ["contact times"]
        + [f"peak {p}" for p in events.get("peak_probes", [])]
    )
    measure_events(runs, references, reference_of, study, methods, measures)
    write_csv(
        os.path.join(out, "runs.csv"),
        ["run", "method", "swept_value", "exit", "wall_time", "unpaired_contacts"] + [f"error {m}" for m in measures],
        [
            [r.id, r.labels["method"], r.labels["value"], r.code, r.wall, r.measured["unpaired"]]
            + [r.measured["errors"][m] for m in measures]
            for r in runs
        ],
    )
    simulated = float(scenario["numerics"]["end_time"]) - float(scenario["numerics"].get("start_time", 0.0))
    peer_wall = peer["wall_time"] * simulated / peer["simulated_time"] if peer else None
    plot_events(os.path.join(out, "work_precision.png"), scenario, runs, methods, measures, peer, peer_wall, simulated)
    lines = [
        *report_head("Work against precision", scenario),
        "Each method against its own reference run ("
        + "; ".join(f"'{m['name']}': {references[reference_of[m['name']]].id}" for m in methods)
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
            f"| {r.labels['method']} | {r.labels['value']:.3g} | {r.wall:.3g} | {fmt(r.measured['unpaired'])} | "
            + " | ".join(fmt(r.measured["errors"][m]) for m in measures)
            + " |"
        )
    lines += ["", failures_section(runs + references)]
    write_report(out, lines)
    return {"runs": runs, "measures": measures}


def plan_references(scenario_path, study, methods, sets, out):
    """Each method's reference run (its own `reference`, else study.reference_run; one run for
    equal specs), refused (exit 2) if a method has none: returns (the reference runs,
    {method name: index in them})."""
    references, keys, reference_of = [], {}, {}
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
                Run(
                    id=f"reference {spec.get('name', len(references))}",
                    reference=True,
                    scenario=run_scenario(scenario_path, spec),
                    sets=list(sets) + list(spec.get("set", [])),
                    contact_probes=list(spec.get("contact_probes", [])),
                    out=os.path.join(out, "runs", f"reference{len(references)}"),
                )
            )
        reference_of[method["name"]] = keys[key]
    return references, reference_of


def measure_events(runs, references, reference_of, study, methods, measures):
    """Each run's errors against its method's reference (`measured["errors"]` by measure, nan for a
    failed run) and its contacts left unpaired (`measured["unpaired"]`)."""
    events = study["events"]
    ref_histories = [read_histories(r.out) for r in references]
    ref_values = [Reference(study, h) for h in ref_histories]
    by_name = {method["name"]: method for method in methods}
    for r in runs:
        k = reference_of[r.labels["method"]]
        reference, ref_run = ref_histories[k], references[k]
        r.measured["errors"], r.measured["unpaired"] = {m: float("nan") for m in measures}, float("nan")
        if r.code != 0:
            continue
        history = read_histories(r.out)
        for p in events.get("history_probes", []):
            r.measured["errors"][f"history {p}"] = (
                probe_error(history, ref_values[k], p, study) if p in reference else float("nan")
            )
        found, r.measured["unpaired"] = event_errors(
            history, by_name[r.labels["method"]].get("contact_probes", []), reference, ref_run.contact_probes, events
        )
        r.measured["errors"].update(found)


def plot_events(path, scenario, runs, methods, measures, peer, peer_wall, simulated):
    """One panel per measure: error against the wall time of the steps, a line per method; a
    peer's wall time for the same simulated span (study.peer) marked for scale."""
    columns = 2
    rows = (len(measures) + columns - 1) // columns
    fig, axes = plt.subplots(rows, columns, figsize=(11, 3.6 * rows), squeeze=False)
    units = {"contact times": "[s]"}
    for ax, measure in zip(axes.flat, measures):
        for method in methods:
            pts = sorted(
                (r.wall, r.measured["errors"][measure])
                for r in runs
                if r.labels["method"] == method["name"]
                and r.measured["errors"][measure] == r.measured["errors"][measure]
                and r.measured["errors"][measure] > 0
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
    save_plot(fig, [ax for ax in axes.flat if ax.has_data()], path, legend_size=7)


def study_work_precision(runner, scenario_path, out, sets):
    scenario, study, sets = with_study_sets(runner, scenario_path, sets)
    steps = halving_steps(scenario, study)
    methods = study.get("methods") or default_methods(scenario)
    runs = plan_work_precision(scenario_path, scenario, methods, steps, sets, out)
    if study.get("events"):
        return study_work_precision_events(runner, scenario_path, scenario, study, sets, runs, methods, out)
    runs, reference, extra_runs, histories, probes = run_and_measure(
        runner, runs, scenario_path, scenario, study, steps, out, "work-precision", sets
    )
    for r, hist in zip(runs, histories):
        errs = [probe_error(hist, reference, p, study) for p in probes] if hist else [float("nan")]
        r.measured["error"] = max(errs) if all(e == e for e in errs) else float("nan")
    write_csv(
        os.path.join(out, "runs.csv"),
        ["run", "method", "swept_value", "exit", "wall_time", "error"],
        [[r.id, r.labels["method"], r.labels["value"], r.code, r.wall, r.measured["error"]] for r in runs],
    )
    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    for method in methods:
        pts = sorted(
            (r.wall, r.measured["error"])
            for r in runs
            if r.labels["method"] == method["name"]
            and r.measured["error"] == r.measured["error"]
            and r.measured["error"] > 0
        )
        if pts:
            ax.loglog(*zip(*pts), "o-", label=method["name"])
    ax.set_xlabel("wall time of the time steps [s]")
    ax.set_ylabel("error, largest over the probes [probe units]")
    ax.set_title(f"{scenario['name']}: work against precision\n({', '.join(probes)})", fontsize=10)
    save_plot(fig, [ax], os.path.join(out, "work_precision.png"))
    lines = [
        *report_head("Work against precision", scenario),
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
        lines.append(f"| {r.labels['method']} | {r.labels['value']:.3g} | {r.wall:.3g} | {fmt(r.measured['error'])} |")
    lines += ["", failures_section(runs + extra_runs)]
    write_report(out, lines)
    return {"runs": runs, "probes": probes}


def plan_work_precision(scenario_path, scenario, methods, steps, sets, out):
    """One Run per method and swept value (study.methods[].sweep_field, the step by default): a
    tolerance swept runs on the coarsest step, a step swept writes the coarsest run's times."""
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
                Run(
                    id=f"{method['name']} {field.split('.')[-1]}={v:.3g}",
                    labels={"method": method["name"], "value": v},
                    scenario=path,
                    sets=list(sets) + list(method.get("set", [])) + extra,
                    out=os.path.join(out, "runs", f"m{m}_{i}"),
                )
            )
    return runs
