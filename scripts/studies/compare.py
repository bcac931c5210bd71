"""The compare study: runs of one scene on the same axes, their differences and contact episodes."""
import os

import numpy as np
import matplotlib

from studies.common import (
    report_head,
    compare_run_scenario,
    contact_episodes,
    fail,
    failures_section,
    Run,
    fmt,
    history_table,
    read_histories,
    save_plot,
    start_from,
    StudyError,
    with_study_sets,
    write_csv,
    write_report,
)

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402 - after matplotlib.use("Agg") (no display)


def study_compare(runner, scenario_path, out, sets):
    """Runs of one scene drawn on the same axes (study.compare: e.g. co-simulated and continuous
    contact), their differences (RMS and peak, against the first run on its output times) and each
    stop contact (study.compare[].contact_probes): start, end, the peaks of study.probes in it."""
    scenario, study, sets = with_study_sets(runner, scenario_path, sets)
    specs, probes = validate_compare(scenario_path, study)
    runs, recorded = plan_compare(scenario_path, specs, sets, out)
    to_run = [r for r in runs if not r.labels.get("recorded")]
    settle_statically(runner, [r for r in to_run if r.labels["settle"]], out)
    runner.run_all([r for r in to_run if r.code is None])
    histories = [recorded[i] if i in recorded else read_histories(r.out) for i, r in enumerate(runs)]
    check_probes(runs, histories, probes)
    diff_rows = differences(runs, histories, probes)
    units = [{} if r.labels.get("recorded") else probe_units(runner, r) for r in runs]
    contact_rows = contact_rows_of(runs, histories, probes, units)
    measure_rows = [
        [m.get("name", m.get("probe", "?"))] + [compare_measure(h, m) for h in histories]
        for m in study.get("measures", [])
    ]
    write_compare_csvs(out, runs, probes, diff_rows, contact_rows, measure_rows)
    plot_compare(os.path.join(out, "compare.png"), scenario, runs, histories, probes)
    lines = [
        *report_head("Compared", scenario),
        "![compare](compare.png)",
        "",
        *runs_table(runs),
        *measures_table(runs, study.get("measures", []), measure_rows),
        *differences_table(runs, diff_rows),
        *contacts_table(runs, probes, contact_rows),
        "",
        failures_section(runs),
    ]
    write_report(out, lines)
    return {"runs": runs, "differences": diff_rows, "contacts": contact_rows}


def validate_compare(scenario_path, study):
    """study.compare (two runs or more), study.probes and study.measures checked, refused (exit 2)
    naming the field; returns (the compare specs, the probes drawn)."""
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
    return specs, probes


def plan_compare(scenario_path, specs, sets, out):
    """One Run per study.compare entry; a recorded history (history_file) is read, not run:
    returns (the runs, {index: recorded history})."""
    runs, recorded = [], {}
    for i, spec in enumerate(specs):
        run = Run(
            id=spec.get("name", f"run{i}"),
            scenario="",
            sets=list(sets) + list(spec.get("set", [])),
            contact_probes=list(spec.get("contact_probes", [])),
            out=os.path.join(out, "runs", f"r{i}"),
        )
        if spec.get("history_file"):  # another code's recorded history: read, not run
            recorded[i] = recorded_history(scenario_path, spec, i)
            run.scenario, run.code, run.labels["recorded"] = spec["history_file"], 0, True
        else:
            run.scenario = compare_run_scenario(scenario_path, spec, i)
            run.labels["settle"] = bool(spec.get("settle_statically"))
        runs.append(run)
    return runs, recorded


def check_probes(runs, histories, probes):
    """A run that completed has every probe drawn and its contact probes, else the study stops (exit 2)."""
    for r, h in zip(runs, histories):
        missing = [p for p in probes + r.contact_probes if p not in h]
        if missing and r.code == 0:
            fail(
                f"run '{r.id}' has no probe(s) {', '.join(missing)} (its history has {', '.join(sorted(h)) or 'none'})"
            )


def differences(runs, histories, probes):
    """Differences against the first run, on its output times within the common span: rows of
    differences.csv (run, probe, RMS, signed peak, its time, the reference's signed peak)."""
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
                    r.id,
                    p,
                    float(np.sqrt(np.mean(d * d))),
                    float(d[k]),  # signed: this run above (+) or below (−) the reference there
                    float(t0[inside][k]),
                    signed_peak(v0[inside]),
                ]
            )
    return diff_rows


def contact_rows_of(runs, histories, probes, units):
    """Each contact episode of each run's contact probes: rows of contacts.csv (run, probe, number,
    start, end, signed peak, unit, then each probe's signed peak within). `units`: each run's
    {probe: unit} (a pad's IMPULSE per step, a twin's CONTACT_FORCE, a joint stop's
    REACTION_MOMENT: one column held all three, without a word)."""
    contact_rows = []
    for r, h, run_units in zip(runs, histories, units):
        for cp in r.contact_probes:
            if cp not in h:
                continue
            t, v = h[cp]
            for n, (a, b, i0, i1) in enumerate(contact_episodes(t, v)):
                row = [r.id, cp, n + 1, float(a), float(b), signed_peak(v[i0 : i1 + 1]), run_units.get(cp, "")]
                for p in probes:
                    if p in h:
                        tp, vp = h[p]
                        window = (tp >= a) & (tp <= b)
                        row.append(signed_peak(vp[window]) if window.any() else float("nan"))
                    else:
                        row.append(float("nan"))
                contact_rows.append(row)
    return contact_rows


def write_compare_csvs(out, runs, probes, diff_rows, contact_rows, measure_rows):
    """differences.csv, measures.csv (if any measure), contacts.csv and runs.csv."""
    write_csv(
        os.path.join(out, "differences.csv"), ["run", "probe", "rms", "peak", "peak_time", "reference_peak"], diff_rows
    )
    if measure_rows:
        write_csv(os.path.join(out, "measures.csv"), ["measure"] + [r.id for r in runs], measure_rows)
    write_csv(
        os.path.join(out, "contacts.csv"),
        ["run", "contact_probe", "contact", "start", "end", "peak_contact", "contact_unit"]
        + [f"peak_{p}" for p in probes],
        contact_rows,
    )
    write_csv(
        os.path.join(out, "runs.csv"),
        ["run", "exit", "wall_time", "process_seconds", "steps", "coupling_iterations_per_step"],
        [
            [
                r.id,
                r.code,
                r.wall,
                r.seconds,
                (r.summary or {}).get("steps", ""),
                ((r.summary or {}).get("coupling_iterations") or {}).get("mean_per_step", ""),
            ]
            for r in runs
        ],
    )


def plot_compare(path, scenario, runs, histories, probes):
    """The figure: one axis per probe, every run on it."""
    fig, axes = plt.subplots(len(probes), 1, figsize=(7.5, 2.1 * len(probes)), sharex=True)
    axes = np.atleast_1d(axes)
    styles = ["-", "--", ":", "-."]
    for ax, p in zip(axes, probes):
        for i, (r, h) in enumerate(zip(runs, histories)):
            if p in h:
                ax.plot(h[p][0], h[p][1], styles[i % len(styles)], lw=1.0, label=r.id)
        ax.set_ylabel(p, fontsize=8)
    axes[-1].set_xlabel("time [s]")
    title = " against ".join(r.id for r in runs) if len(runs) <= 3 else f"{len(runs)} runs against '{runs[0].id}'"
    axes[0].set_title(f"{scenario['name']}: {title}", fontsize=10)
    save_plot(fig, list(axes), path)


def runs_table(runs):
    """The report's table of the runs: exit, wall times, steps, coupling iterations."""
    lines = [
        "| run | exit | wall time of the steps [s] | process [s] | steps | coupling iterations per step |",
        "|---|---|---|---|---|---|",
    ]
    for r in runs:
        s_ = r.summary or {}
        if r.labels.get("recorded"):
            lines.append(f"| {r.id} | recorded: {r.scenario} | — | — | — | — |")
            continue
        lines.append(
            f"| {r.id} | {r.code} | {r.wall:.1f} | {r.seconds:.1f} | {s_.get('steps', '—')} | "
            f"{fmt((s_.get('coupling_iterations') or {}).get('mean_per_step', float('nan')))} |"
        )
    return lines


def differences_table(runs, diff_rows):
    """The report's table of differences.csv."""
    lines = [
        "",
        f"Differences from '{runs[0].id}' on its output times "
        "(RMS, largest and when; the reference's largest |value| for scale):",
        "",
        "| run | probe | RMS | peak | at [s] | reference peak |",
        "|---|---|---|---|---|---|",
    ]
    for row in diff_rows:
        lines.append(f"| {row[0]} | {row[1]} | {fmt(row[2])} | {fmt(row[3])} | {row[4]:.3f} | {fmt(row[5])} |")
    return lines


def contacts_table(runs, probes, contact_rows):
    """The report's table of contacts.csv: at most 12 episodes of each run's contact probe, then
    how many more the CSV holds."""
    lines = []
    if any(r.contact_probes for r in runs):  # scenes without stops have no contact table
        lines += [
            "",
            "Stop contacts (samples where the contact probe is non-zero; the peaks of each probe within,"
            " signed: the value of largest magnitude):",
            "",
            "| run | contact probe | # | start [s] | end [s] | peak contact | unit | "
            + " | ".join(f"peak {p}" for p in probes)
            + " |",
            "|---|---|---|---|---|---|---|" + "---|" * len(probes),
        ]
    shown = {}
    for row in contact_rows:
        key = (row[0], row[1])
        shown[key] = shown.get(key, 0) + 1
        if shown[key] <= 12:
            lines.append(
                "| "
                + " | ".join(
                    [row[0], row[1], str(row[2]), f"{row[3]:.3f}", f"{row[4]:.3f}", fmt(row[5]), row[6]]
                    + [fmt(x) for x in row[7:]]
                )
                + " |"
            )
    for key, n in shown.items():
        if n > 12:
            lines.append(f"| {key[0]} | {key[1]} | … {n - 12} more in contacts.csv | | | | " + " | " * len(probes))
    return lines


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
        numerics = runner.scenario_json(r.scenario, r.sets).get("numerics", {})
        t1 = float(numerics.get("start_time", 0.0)) + float(numerics["step"])
        r.labels["settled_at"] = t1
        statics.append(
            Run(
                id=f"{r.id}: static equilibrium at t = {t1:g} s",
                scenario=r.scenario,
                sets=r.sets + ["numerics.smooth.analysis=STATIC", f"numerics.end_time={t1!r}"],
                out=r.out + "-static",
            )
        )
    for r, st in zip(runs, runner.run_all(statics)):
        state = os.path.abspath(os.path.join(st.out, "final_state.pb"))
        if not st.ok or not os.path.isfile(state):
            # The run is reported failed with the static step's reason; it is not started.
            r.code, r.summary = st.code or 3, st.summary
            r.message = f"its static equilibrium failed: {st.message}"
            continue
        r.sets = r.sets + start_from(state, r.labels["settled_at"])


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
        f"Measures (differences from '{runs[0].id}'; ✓ within the agreement asked, ✗ not):",
        "",
        "| measure | " + " | ".join(r.id for r in runs) + " | agreement |",
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


def signed_peak(values):
    """The value of largest magnitude, with its sign (a peak that is a trough stays one)."""
    values = np.asarray(values, dtype=float)
    return float(values[int(np.argmax(np.abs(values)))]) if values.size else float("nan")


# Units of the probe quantities a stop's contact is measured by (proto/scenario/output.proto, Probe).
QUANTITY_UNITS = {
    "IMPULSE": "N s (per step)",
    "CONTACT_FORCE": "N",  # a point contact's; a joint stop's is N m (probe_units)
    "REACTION_FORCE": "N",
    "REACTION_MOMENT": "N m",
    "GAP": "m",
    "POSITION": "m",
    "VELOCITY": "m/s",
    "JOINT_COORDINATE": "rad or m",
    "JOINT_SPEED": "rad/s or m/s",
}


def probe_units(runner, run):
    """{probe name: unit} of a run's probes, from its scenario as the solvers read it."""
    try:
        scenario = runner.scenario_json(run.scenario, run.sets)
    except StudyError:
        return {}
    # A joint stop's CONTACT_FORCE is its law's moment (proto/scenario/output.proto): the Puma twin's stops.
    joint_stops = {f.get("name") for f in scenario.get("model", {}).get("forces", []) if "joint_stop" in f}
    units = {}
    for p in scenario.get("output", {}).get("probes", []):
        quantity = p.get("quantity", "")
        unit = (
            "N m"
            if quantity == "CONTACT_FORCE" and p.get("entity") in joint_stops
            else QUANTITY_UNITS.get(quantity, "")
        )
        scale = float(p.get("scale", 1.0))
        units[p.get("name", "")] = unit if scale == 1.0 or not unit else f"{unit} × {scale:g}"
    return units
