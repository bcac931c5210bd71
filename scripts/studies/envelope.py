"""The envelope study: a scene over a grid of one or two named quantities, per point the tips'
clearance, stop loads and impacts; polar or grid plots and the operating-limits diagram."""
import os
import re
import time

import numpy as np
import matplotlib

from studies.common import (
    report_head,
    SAFE_MATH,
    contact_episodes,
    fail,
    failures_section,
    fmt,
    read_histories,
    Run,
    settled_start,
    with_study_sets,
    write_csv,
    write_report,
)

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402 - after matplotlib.use("Agg") (no display)


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
    spec, axes = validate_envelope(scenario_path, study)
    # study.restart_time: every point starts from one run's state there (co-simulated scenes
    # too: each contact process's state travels with the smooth solver's); the axes' overrides
    # must not act before that time (a gust that has not reached the rotor). The settling run
    # takes the study's overrides, not the envelope's own `set`, which are its points' only (the
    # schema's word): with `numerics.smooth.settle=false` there it switched off the settle of the
    # run every point started from, and each point continued an unsettled, ringing start.
    restart_sets, restart_note = settled_start(
        runner, scenario_path, scenario, study, sets, out, "the measures are the window's, without the start-up"
    )
    names, runs = plan_envelope(scenario_path, spec, axes, list(sets) + restart_sets, out)
    # Every override checked before any run: a bad field path is the study's input error.
    runner.scenario_json(scenario_path, runs[0].sets)
    runs = runner.run_all(runs)
    rows = measure_envelope(runs, spec, scenario)
    write_csv(
        os.path.join(out, "runs.csv"), names + ["exit", "wall_time", "simulated_time", "host"] + ENVELOPE_COLUMNS, rows
    )
    measures = [(k, label) for k, label in ENVELOPE_MEASURES if any(np.isfinite(r.measured[k]) for r in runs)]
    plot_envelope(runs, axes, names, measures, os.path.join(out, "envelope.png"), scenario["name"])
    limits_note = plot_operating_limits(
        runs, axes, names, spec, os.path.join(out, "operating_limits.png"), scenario["name"]
    )
    elapsed = time.time() - started
    cpu = sum(r.seconds for r in runs if r.seconds == r.seconds)
    took = (
        f"; the study took {elapsed:.0f} s on {runner.cluster().workers()} Dask workers "
        f"({'scheduler ' + runner.scheduler if runner.scheduler else 'local cluster'}), the runs {cpu:.0f} s "
        f"one after the other (processes' wall time)."
        if any(r.host != "kept" for r in runs)
        else f"; every run kept from an earlier study (--reuse): the runs took {cpu:.0f} s one after the other."
    )
    lines = (
        envelope_report_head(scenario, spec, runs, axes, names, took, restart_note, limits_note)
        + envelope_rows(runs)
        + worst_points(runs)
        + ["", failures_section(runs)]
    )
    write_report(out, lines)
    if not any(r.code == 0 for r in runs):
        # Failed points are data (a rotor that finds no rest in a strong wind), but an envelope of
        # which no point completed measured nothing: its report and runs.csv are written, and the
        # study ends as its runs did (2 when each was refused as bad input, else 3).
        codes = sorted({r.code for r in runs})
        first = runs[0]
        fail(
            f"{scenario_path}: no point of the envelope completed (exits {', '.join(str(c) for c in codes)}); "
            f"the first, {first.id}: {first.message}",
            2 if codes == [2] else 3,
        )
    return {"runs": runs}


def validate_envelope(scenario_path, study):
    """study.envelope checked (one or two axes, each with values and overrides, something to
    measure), refused (exit 2) naming the field; returns (study.envelope, its axes)."""
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
    return spec, axes


def plan_envelope(scenario_path, spec, axes, sets, out):
    """One Run per point of the grid (the first axis's values, times the second's), with the
    study's overrides `sets`, the envelope's own and the point's; returns (the axes' names, the runs)."""
    where = f"{scenario_path}: study.envelope"
    sets = list(sets) + list(spec.get("set", []))
    if spec.get("impulse_probes"):
        sets.append("output.every=1")  # every step's impulse: none missed between rows
    names = [a.get("name") or f"axis{i}" for i, a in enumerate(axes)]
    grid = [[v] for v in axes[0]["values"]]
    if len(axes) == 2:
        grid = [[v0, v1] for v0 in axes[0]["values"] for v1 in axes[1]["values"]]
    runs = []
    for i, point in enumerate(grid):
        point_sets = [s_ for a, v in zip(axes, point) for s_ in axis_sets(a, v, f"{where}.axes[{axes.index(a)}]")]
        label = ", ".join(f"{n} = {v:g}" for n, v in zip(names, point))
        runs.append(
            Run(
                id=label,
                labels={"point": point},
                scenario=scenario_path,
                sets=sets + point_sets,
                out=os.path.join(out, "runs", f"p{i}"),
            )
        )
    return names, runs


def measure_envelope(runs, spec, scenario):
    """Each run's envelope_point (into its `measured`), and runs.csv's rows."""
    rows = []
    for r in runs:
        summary = r.summary or {}
        step = (summary.get("numerics") or {}).get("step") or scenario["numerics"].get("step", 1.0)
        m = envelope_point(read_histories(r.out), spec, float(step))
        r.measured.update(m)
        rows.append(
            list(r.labels["point"])
            + [r.code, r.wall, summary.get("simulated_time", float("nan")), r.host]
            + [m[k] for k in ENVELOPE_COLUMNS]
        )
    return rows


def envelope_report_head(scenario, spec, runs, axes, names, took, restart_note, limits_note):
    """The report down to its table's header: the grid, what the study took (`took`), the
    figures, what each measure is."""
    return (
        [
            *report_head("Envelope", scenario),
            f"{len(runs)} runs over "
            + " × ".join(f"{n} ({len(a['values'])} values)" for n, a in zip(names, axes))
            + took,
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


def envelope_rows(runs):
    """The report's table: one row per point, a failed one's exit in bold with where it stopped."""
    lines = []
    for r in runs:
        m = r.measured
        exit_text = (
            "0" if r.code == 0 else f"**{r.code}** (t = {fmt((r.summary or {}).get('simulated_time', float('nan')))} s)"
        )
        lines.append(
            "| " + " | ".join(f"{v:g}" for v in r.labels["point"]) + f" | {exit_text} | {fmt(m['tip_lowest'])} "
            f"({m['tip_lowest_probe']}, {fmt(m['tip_lowest_time'])}) | {fmt(m['tip_highest'])} | "
            f"{fmt(m['tip_down'])} / {fmt(m['tip_up'])} | {fmt(m['clearance'])} | {fmt(m['peak_stop_force'])} | "
            f"{fmt(m['impacts'])} | {r.wall:.1f} |"
        )
    return lines


def worst_points(runs):
    """The report's worst completed points for each measure (none if no run completed)."""
    ok = [r for r in runs if r.code == 0]
    if not ok:
        return []
    lines = ["", "Worst points (completed runs):", ""]
    for key, label, worst in (
        ("tip_lowest", "lowest tip", min),
        ("clearance", "smallest clearance", min),
        ("peak_stop_force", "largest stop force", max),
        ("impacts", "most impacts", max),
    ):
        finite = [r for r in ok if np.isfinite(r.measured[key])]
        if finite:
            r = worst(finite, key=lambda x: x.measured[key])
            lines.append(f"- {label}: {fmt(r.measured[key])} at {r.id}")
    return lines


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
        values = np.array([r.measured[key] for r in runs], dtype=float)
        failed = np.array([r.code != 0 for r in runs])
        if len(axes) == 1:
            x = np.array([r.labels["point"][0] for r in runs])
            order = np.argsort(x)
            ax.plot(x[order], values[order], "o-")
            ax.plot(x[failed], values[failed], "rx", ms=9, label="failed run")
            ax.set_xlabel(f"{names[0]} [{axes[0].get('unit', '')}]")
            ax.set_ylabel(label)
        else:
            a0 = np.array([r.labels["point"][0] for r in runs])
            a1 = np.array([r.labels["point"][1] for r in runs])
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
        c = r.measured["clearance"]
        if r.code != 0:
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
    clearances = np.array([r.measured["clearance"] for r in runs], dtype=float)
    finite = clearances[np.isfinite(clearances)]
    norm = plt.Normalize(finite.min(), finite.max()) if len(finite) else plt.Normalize(0, 1)
    cmap = plt.get_cmap("viridis")
    fig = plt.figure(figsize=(6.4, 6.0))
    ax = fig.add_subplot(projection="polar")
    if axes[1].get("compass"):
        ax.set_theta_zero_location("N")
        ax.set_theta_direction(-1)
    for r, unsafe, c in zip(runs, flags, clearances):
        speed, direction = r.labels["point"]
        i = speeds.index(speed)
        # The point's cell: its direction's sector between its speed's ring edges.
        cell = dict(
            x=np.radians(direction), height=r_edges[i + 1] - r_edges[i], width=np.radians(step), bottom=r_edges[i]
        )
        colour = cmap(norm(c)) if np.isfinite(c) else (0.85, 0.85, 0.85, 1)
        ax.bar(**cell, color=colour, edgecolor="white", linewidth=0.5)
        if unsafe:
            ax.bar(**cell, fill=False, hatch="///", edgecolor="red", linewidth=0.0)
        if r.code != 0:
            ax.plot(np.radians(direction), speed, "rx", ms=8, mew=2)
    # The boundary: per direction, the lowest unsafe speed's inner edge.
    boundary = []
    for d in directions:
        at = [(r.labels["point"][0], f) for r, f in zip(runs, flags) if r.labels["point"][1] == d and f]
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
    failed = sum(1 for r in runs if r.code != 0)
    return (
        f"Operating limits: {n_unsafe} of {len(runs)} points unsafe (clearance below {threshold:g} m"
        + (f", or one of the {failed} failed runs" if failed else "")
        + "); the red line bounds the safe region "
        "from inside (per direction, the lowest unsafe wind speed's cell)."
    )
