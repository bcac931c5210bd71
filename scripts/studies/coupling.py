"""The coupling study: coupling iterations per step, residual histories and wall time as the
relaxation, the reaction tolerance and the step vary."""
import os

import numpy as np
import matplotlib

from studies.common import (
    report_head,
    EXIT_MEANING,
    Run,
    fail,
    failures_section,
    fmt,
    save_plot,
    with_study_sets,
    write_csv,
    write_report,
)

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402 - after matplotlib.use("Agg") (no display)


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
    runs = runner.run_all(plan_coupling(scenario_path, relaxations, tolerances, steps, sets, out))
    for r in runs:
        it = (r.summary or {}).get("coupling_iterations", {})
        r.measured["mean"], r.measured["max"] = it.get("mean_per_step", float("nan")), it.get(
            "max_per_step", float("nan")
        )
    write_csv(
        os.path.join(out, "runs.csv"),
        ["run", "relaxation", "reaction_tolerance", "step", "exit", "mean_iterations", "max_iterations", "wall_time"],
        [
            [
                r.id,
                r.labels["relaxation"],
                r.labels["tol"],
                r.labels["h"],
                r.code,
                r.measured["mean"],
                r.measured["max"],
                r.wall,
            ]
            for r in runs
        ],
    )
    plot_iterations(os.path.join(out, "iterations.png"), scenario, runs, relaxations, steps)
    plot_residuals(os.path.join(out, "residuals.png"), scenario, runs, relaxations, tolerances, steps)
    write_report(out, coupling_report(scenario, runs))
    return {"runs": runs}


def plan_coupling(scenario_path, relaxations, tolerances, steps, sets, out):
    """One Run per relaxation, reaction tolerance and step."""
    runs = []
    for relax in relaxations:
        for tol in tolerances:
            for h in steps:
                runs.append(
                    Run(
                        id=f"{relax} tol={tol:g} h={h:g}",
                        labels={"relaxation": relax, "tol": tol, "h": h},
                        scenario=scenario_path,
                        sets=list(sets)
                        + relaxation_sets(relax)
                        + [f"coupling.iteration.reaction_tolerance={tol!r}", f"numerics.step={h!r}"],
                        out=os.path.join(
                            out, "runs", f"{relax}_{tol:g}_{h:g}".replace(".", "p").replace("(", "_").replace(")", "")
                        ),
                    )
                )
    return runs


def plot_iterations(path, scenario, runs, relaxations, steps):
    """Iterations per step and wall time against the reaction tolerance, a line per relaxation and step."""
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for c, relax in enumerate(relaxations):
        for h, style in zip(steps, ("o-", "s--", "^:", "v-.")):
            kw = {"color": colours[c % len(colours)], "label": f"{relax}, h = {h:g} s"}
            pts = [
                (r.labels["tol"], r.measured["mean"])
                for r in runs
                if r.labels["relaxation"] == relax and r.labels["h"] == h and r.code == 0
            ]
            if pts:
                axes[0].semilogx(*zip(*sorted(pts)), style, **kw)
            pts = [
                (r.labels["tol"], r.wall)
                for r in runs
                if r.labels["relaxation"] == relax and r.labels["h"] == h and r.code == 0
            ]
            if pts:
                axes[1].loglog(*zip(*sorted(pts)), style, **kw)
    axes[0].set_xlabel("reaction tolerance (relative)")
    axes[0].set_ylabel("coupling iterations per step (mean)")
    axes[1].set_xlabel("reaction tolerance (relative)")
    axes[1].set_ylabel("wall time [s]")
    fig.suptitle(f"{scenario['name']}: coupling iterations (failed runs left out, see the table)")
    save_plot(fig, axes, path, legend_size=7)


def plot_residuals(path, scenario, runs, relaxations, tolerances, steps):
    """Residual histories: the step with the most iterations, tightest tolerance, coarsest step."""
    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    for relax in relaxations:
        match = [
            r
            for r in runs
            if r.labels["relaxation"] == relax and r.labels["tol"] == min(tolerances) and r.labels["h"] == steps[0]
        ]
        log_path = os.path.join(match[0].out, "coupling.csv") if match else ""
        if not os.path.isfile(log_path):
            continue
        log = np.genfromtxt(log_path, delimiter=",", names=True, ndmin=1)
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
    save_plot(fig, [ax], path)


def coupling_report(scenario, runs):
    """report.md's lines: the figures and a row per run."""
    lines = [
        *report_head("Coupling", scenario),
        "![iterations](iterations.png)",
        "",
        "![residuals](residuals.png)",
        "",
        "| relaxation | reaction tolerance | step [s] | exit | iterations/step (mean) | max | wall [s] |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in runs:
        lines.append(
            f"| {r.labels['relaxation']} | {r.labels['tol']:g} | {r.labels['h']:g} "
            f"| {r.code} ({EXIT_MEANING.get(r.code, '?')}) | "
            f"{fmt(r.measured['mean'])} | {fmt(r.measured['max'])} | {r.wall:.3g} |"
        )
    lines += ["", failures_section(runs)]
    return lines
