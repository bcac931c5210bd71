"""The convergence study: the time step halved, each probe's error against a reference, the
observed order as a fitted slope."""
import os

import numpy as np
import matplotlib

from studies.common import (
    report_head,
    every_for,
    failures_section,
    fitted_order,
    fmt,
    halving_steps,
    probe_error,
    Run,
    run_and_measure,
    save_plot,
    settled_start,
    with_study_sets,
    write_csv,
    write_report,
)

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402 - after matplotlib.use("Agg") (no display)


def study_convergence(runner, scenario_path, out, sets):
    scenario, study, sets = with_study_sets(runner, scenario_path, sets)
    restart_sets, restart_note = settled_start(runner, scenario_path, scenario, study, sets, out)
    sets = list(sets) + restart_sets
    steps = halving_steps(scenario, study)
    runs = [
        Run(
            id=f"h={h:.4g}",
            labels={"h": h},
            scenario=scenario_path,
            sets=list(sets) + [f"numerics.step={h!r}", f"output.every={every_for(scenario, h, steps[0])}"],
            out=os.path.join(out, "runs", f"h{i}"),
        )
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
        [[r.id, r.labels["h"], r.code, r.wall] + [errors[p][i] for p in probes] for i, r in enumerate(runs)],
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
    reference_kind = (
        "analytic (study.references)"
        if study.get("references")
        else "a finer run"
        if not study.get("reference_run")
        else "study.reference_run"
    )
    lines = [
        *report_head("Convergence", scenario),
        f"Reference: {reference_kind}; "
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
