"""The timing study: wall time of a scene's runs with and without output, against study.peer."""
import os
from studies.common import (
    report_head,
    compare_run_scenario,
    failures_section,
    fmt,
    Run,
    study_peer,
    with_study_sets,
    write_csv,
    write_report,
)


def study_timing(runner, scenario_path, out, sets):
    """Wall time of a scene's runs (study.compare, else the scene itself), each with its output as
    written and without (a history row only at the first and last step), one run at a time so
    that they do not share the cores; per simulated second, and as a ratio to study.peer."""
    scenario, study, sets = with_study_sets(runner, scenario_path, sets)
    specs = study.get("compare") or [{"name": scenario["name"]}]
    peer = study_peer(scenario_path, study)
    runs = plan_timing(scenario_path, specs, sets, out)
    jobs, runner.jobs = runner.jobs, 1  # timings: alone on the machine (as far as this study goes)
    try:
        for r in runs:
            r.measured["load_before"] = os.getloadavg()[0]
            runner.run_all([r])
    finally:
        runner.jobs = jobs
    rows = [timing_row(r, peer) for r in runs]
    write_csv(os.path.join(out, "timing.csv"), TIMING_COLUMNS, rows)
    write_report(out, timing_report(scenario, peer, runs, rows))
    return {"runs": runs, "rows": rows}


def plan_timing(scenario_path, specs, sets, out):
    """Two runs of each spec: its output as written, and none (a row at the first and last step)."""
    runs = []
    for i, spec in enumerate(specs):
        path = compare_run_scenario(scenario_path, spec, i)
        for output in ("as written", "none"):
            extra = [] if output == "as written" else ["output.every=1000000000"]
            runs.append(
                Run(
                    id=f"{spec.get('name', f'run{i}')}: output {output}",
                    labels={"name": spec.get("name", f"run{i}"), "output": output},
                    scenario=path,
                    sets=list(sets) + list(spec.get("set", [])) + extra,
                    out=os.path.join(out, "runs", f"r{i}_{'out' if output == 'as written' else 'none'}"),
                )
            )
    return runs


# timing.csv's columns, timing_row's order.
TIMING_COLUMNS = [
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


def timing_row(r, peer):
    """A run's row of timing.csv: its wall time per simulated second, and the peer's over it."""
    s_ = r.summary or {}
    simulated = s_.get("simulated_time", float("nan"))
    per_second = r.wall / simulated if simulated and simulated == simulated else float("nan")
    ratio = (peer["wall_time"] / peer["simulated_time"]) / per_second if peer and per_second > 0 else float("nan")
    return [
        r.id,
        r.code,
        s_.get("steps", ""),
        simulated,
        r.wall,
        r.seconds,
        per_second,
        ratio,
        (s_.get("coupling_iterations") or {}).get("mean_per_step", float("nan")),
        (s_.get("newton_iterations") or {}).get("mean_per_step", float("nan")),
        (s_.get("counters") or {}).get("newton_factorizations", ""),
        r.measured["load_before"],
    ]


def timing_report(scenario, peer, runs, rows):
    """report.md's lines: how the runs were timed, the peer, the table of timing.csv."""
    lines = [
        *report_head("Timing", scenario),
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
        cells = [str(row[1]), str(row[2])] + [fmt(x) for x in row[3:10]] + [str(row[10]), f"{row[11]:.2f}"]
        lines.append("| " + " | ".join([row[0]] + cells) + " |")
    lines += [
        "",
        "Real time means a wall time per simulated second of 1 or less. The load average as a run began "
        "still counts the previous run's processes (it decays over a minute): a figure well above the "
        "previous run's process count means something else was running.",
        "",
        failures_section(runs),
    ]
    return lines
