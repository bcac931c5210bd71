"""The stability study: the hard-case table of a folder of scenarios."""
import os

import numpy as np
from studies.common import Run, fail, fmt, read_histories, write_csv, write_report


def study_stability(runner, target, out, sets):
    scenarios = stability_scenarios(target)
    infos, runs = {}, []
    for path in scenarios:
        scenario = runner.scenario_json(path, sets)
        infos[path] = scenario
        runs.append(
            Run(
                id=scenario["name"],
                scenario=path,
                sets=list(sets),
                out=os.path.join(out, "runs", scenario["name"]),
            )
        )
    runs = runner.run_all(runs)
    rows = [stability_row(r, infos[r.scenario]) for r in runs]
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
    write_report(out, stability_report(rows))
    return {"rows": rows}


def stability_scenarios(target):
    """The scenario files of a folder (sorted), or the one file named; refused (exit 2) if none."""
    if os.path.isdir(target):
        scenarios = sorted(os.path.join(target, f) for f in os.listdir(target) if f.endswith(".pbtxt"))
    else:
        scenarios = [target]
    if not scenarios:
        fail(f"{target}: no .pbtxt scenarios")
    return scenarios


def stability_row(r, scenario):
    """A run's row of the table: whether it completes, its largest constraint violation, its
    energy change (of its TOTAL_ENERGY probe), its iterations per step and wall time."""
    s = r.summary or {}
    energy = [p["name"] for p in scenario.get("output", {}).get("probes", []) if p.get("quantity") == "TOTAL_ENERGY"]
    drift = float("nan")
    if energy:
        hist = read_histories(r.out)
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
    return {
        "name": scenario["name"],
        "reason": scenario.get("study", {}).get("reason") or scenario.get("description", ""),
        "code": r.code,
        "completes": r.code == 0,
        "violation": s.get("max_constraint_violation", float("nan")),
        "drift": drift,
        "iterations": ", ".join(iters) or "—",
        "wall": r.wall,
        "steps": s.get("steps", 0),
        "message": r.message if r.code != 0 else "",
    }


def stability_report(rows):
    """report.md's lines: the hard-case table."""
    lines = [
        "# Stability: the hard cases",
        "",
        "Each scene is run once as shipped. Energy change: the largest |E(t) − E(0)| [J] of its TOTAL_ENERGY probe:",
        "a drift where the scene conserves energy, the dissipation where it should dissipate (impacts with e < 1).",
        "",
        "| scene | what it tests | completes | largest constraint violation | energy change [J] "
        "| iterations per step | wall [s] |",
        "|---|---|---|---|---|---|---|",
    ]
    for x in rows:
        done = "yes" if x["completes"] else f"**no** (exit {x['code']}: {x['message']})"
        lines.append(
            f"| {x['name']} | {x['reason']} | {done} | {fmt(x['violation'])} | {fmt(x['drift'])} | "
            f"{x['iterations']} | {x['wall']:.3g} |"
        )
    return lines
