"""The modes study: a scene's natural frequencies (MODES analysis) against its references."""
import csv
import os
import sys
import matplotlib

from studies.common import Run, fail

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402 - after matplotlib.use("Agg") (no display)


def study_modes(runner, scenario_path, out, sets):
    """Fan plot: the scenario's MODES analysis (numerics.smooth.analysis = MODES; the speeds are
    numerics.start_time..end_time by step, the spin axis numerics.smooth.modes.axis, set in the
    file or with --set), frequencies against rotor speed with the per-revolution lines, each mode
    coloured by what its shape does most (flap, lag or radial motion of the nodes)."""
    run = Run(
        id="modes",
        scenario=scenario_path,
        sets=["numerics.smooth.analysis=MODES"] + list(sets),
        out=os.path.join(out, "run"),
    )
    run = runner.run_all([run])[0]
    if run.code != 0:
        fail(f"the MODES run failed (exit {run.code}): {run.message}", run.code)
    with open(os.path.join(run.out, "modes.csv")) as f:
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
