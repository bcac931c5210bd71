"""Every study of docs/results.md, regenerated into docs/."""
import csv
import os
import re
import shutil
import sys
from studies.common import ROOT, StudyError
from studies.kinds import STUDIES


def envelope_headline(runs_csv, speed_unit):
    """The envelope's figures for the results table, from its runs.csv: how many runs, how many
    failed, and the smallest clearance (where: the first two columns are the axes). Points within
    a millimetre of the least are all named, by speed and direction: a rotor's symmetric directions
    reach the same clearance to round-off, and which of them is lowest by 1e-11 m is not a
    finding (it followed the order in which the runs finished)."""
    with open(runs_csv) as f:
        rows = list(csv.DictReader(f))
    axes = list(rows[0])[:2]
    failed = sum(1 for r in rows if r["exit"] != "0")
    done = [r for r in rows if r["exit"] == "0" and r["clearance"] not in ("", "nan")]
    least = min(float(r["clearance"]) for r in done)
    where = sorted(
        (r for r in done if float(r["clearance"]) - least < 1e-3), key=lambda r: (float(r[axes[0]]), float(r[axes[1]]))
    )
    places = []
    for speed in dict.fromkeys(r[axes[0]] for r in where):
        directions = [f"{r[axes[1]]}°" for r in where if r[axes[0]] == speed]
        listed = directions[0] if len(directions) == 1 else f"{', '.join(directions[:-1])} and {directions[-1]}"
        places.append(f"{speed} {speed_unit} from {listed}")
    return f"{len(rows)} runs, {failed} failed; the least clearance {least:.2f} m at {'; '.join(places)}"


def headline_rows(path):
    """The results table's hand-written rows (a reading: table rows, one per line, each naming
    where its figure is checked); refused if a line is not a table row of four cells."""
    with open(path) as f:
        rows = [line.rstrip("\n") for line in f if line.strip()]
    for i, row in enumerate(rows):
        if not (row.startswith("| ") and row.endswith(" |") and row.count(" | ") == 3):
            raise StudyError(f"{path}:{i + 1}: expected a table row '| figure | paper | here | where |', got: {row}")
    return rows


def entry_heading(text, name, entry_sets):
    """A report's first line "# Kind: scenario" as "# Kind: NAME" (entries of one scene differ by
    name), and the settings that make the entry differ from the scene's own on a line below."""
    first, _, rest = text.partition("\n")
    kind = first.split(":", 1)[0]
    settings = ", ".join(f"`{s}`" for s in entry_sets)
    return f"{kind}: {name}\n\nSettings beside the scene's own: {settings}.\n{rest}"


def anchor(title):
    """The link target GitHub gives a heading."""
    return re.sub(r"[^\w\- ]", "", title.strip().lower()).replace(" ", "-")


def contents(sections):
    """A contents block: one link per section ("## " heading) of the generated page."""
    lines = ["Contents:", ""]
    for section in sections:
        title = section.split("\n", 1)[0][3:]
        lines.append(f"- [{title}](#{anchor(title)})")
    return "\n".join(lines) + "\n"


# The studies behind docs/results.md: (kind, name, scenario[, this entry's own overrides]); each
# study's folder is KIND-NAME.
RESULTS_PLAN = [
    ("convergence", "four_bar", "scenarios/four_bar.pbtxt"),
    ("work-precision", "four_bar", "scenarios/four_bar.pbtxt"),
    ("work-precision", "linear_oscillator", "scenarios/linear_oscillator.pbtxt"),
    ("work-precision", "pendulum_stop", "scenarios/pendulum_stop.pbtxt"),
    ("coupling", "pendulum_stop", "scenarios/pendulum_stop.pbtxt"),
    ("stability", "hard", "scenarios/hard"),
    ("stability", "scenarios", "scenarios"),
    ("compare", "puma_gust", "scenarios/puma/gust.pbtxt"),
    ("compare", "puma_engage", "scenarios/puma/engage_disengage.pbtxt"),
    # MBDyn's histories of the same rotor beside the engagement modelled as MBDyn models it,
    # with each of MBDyn's aerodynamic choices undone in turn.
    ("compare", "puma_mbdyn", "scenarios/puma/engage_disengage_mbdyn.pbtxt"),
    ("timing", "puma_engage", "scenarios/puma/engage_disengage.pbtxt"),
    # The engagement's error against wall time, each model against its converged run.
    ("work-precision", "puma_engage", "scenarios/puma/engage_disengage.pbtxt"),
    # The still rotor's blade-sailing envelope: gust peak × direction.
    ("envelope", "puma_gust", "scenarios/puma/gust.pbtxt"),
    # The shipborne engagement's operating-limits envelope: wind speed ×
    # relative wind direction on the moving deck, the continuous twin (108 runs).
    ("envelope", "puma_ship", "scenarios/puma/ship_engage_continuous.pbtxt"),
    # The co-simulated impact response under step refinement: the gust's
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
    # The SHARCS-like hub: the paper's Figs. 9–11 for both blade models, and
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


def results(runner, out_root, sets, reuse=False):
    """The studies behind docs/results.md, their reports copied next to it."""
    docs = os.path.join(ROOT, "docs")
    headline = headline_rows(os.path.join(docs, "readings", "headline.md"))  # (refused before an hour of runs)
    figures = os.path.join(docs, "results")
    os.makedirs(figures, exist_ok=True)
    sections = []
    for kind, name, path, *entry in RESULTS_PLAN:
        entry_sets = entry[0] if entry else []  # this entry's own overrides
        out = os.path.join(out_root, f"{kind}-{name}")
        os.makedirs(out, exist_ok=True)
        if reuse and os.path.isfile(os.path.join(out, "report.md")):
            print(f"cosim study: {kind}-{name}: reusing {out}/report.md", file=sys.stderr)
        else:
            STUDIES[kind](runner, os.path.join(ROOT, path), out, list(sets) + entry_sets)
        sections.append(results_section(out, figures, docs, kind, name, entry_sets))
    header = results_header(headline, out_root)
    with open(os.path.join(docs, "results.md"), "w") as f:
        f.write("\n".join(header) + "\n" + contents(sections) + "\n" + "".join(sections))
    print("cosim study: docs/results.md written", file=sys.stderr)


def results_section(out, figures, docs, kind, name, entry_sets):
    """One study's section of docs/results.md: its report, its figures copied into `figures` as
    KIND-NAME-FIGURE.png and linked there, its entry's settings, the hand-written reading beside it,
    headings one level down."""
    with open(os.path.join(out, "report.md")) as f:
        text = f.read()
    for png in (p for p in os.listdir(out) if p.endswith(".png")):
        target = f"{kind}-{name}-{png}"
        shutil.copy(os.path.join(out, png), os.path.join(figures, target))
        text = text.replace(f"]({png})", f"](results/{target})")
    if entry_sets:  # this entry named in its heading, its settings on the line below
        text = entry_heading(text, name, entry_sets)
    if (kind, name) == ("stability", "scenarios"):
        text = text.replace("# Stability: the hard cases", "# The shipped scenarios, as they run", 1)
    reading = os.path.join(docs, "readings", f"{kind}-{name}.md")
    if os.path.isfile(reading):  # a hand-written reading of the study, kept next to it
        with open(reading) as f:
            text = text.rstrip("\n") + "\n\n" + f.read()
    return text.replace("\n# ", "\n## ").replace("# ", "## ", 1).rstrip("\n") + "\n\n"


def results_header(headline, out_root):
    """docs/results.md's head: how it is made, and the table of headline figures (the hand-written
    rows, then the envelopes' from their runs.csv)."""
    return [
        "# Results",
        "",
        "Regenerated by `scripts/cosim study results` (the studies of scripts/studies on the shipped",
        "scenarios; this machine, 2 cores; about 30 min, most of it the Puma runs, "
        "and 45–100 min more for the 108 runs of the ship envelope; `--reuse` keeps reports already made). "
        "Next to the papers' numbers where they give them:",
        "the envelopes' rows are computed from their runs; the others are readings of the reports below",
        "(docs/readings/headline.md, written by hand from them: a row is rewritten when its report changes).",
        "",
        "| paper's figure | paper | here | where it is checked |",
        "|---|---|---|---|",
        *headline,
        "| Puma blade-sailing envelope, gust peak × direction | — | "
        + envelope_headline(os.path.join(out_root, "envelope-puma_gust", "runs.csv"), "m/s")
        + " (below) | envelope study |",
        "| Puma engagement on a frigate's moving deck in its airwake, operating limits | — | "
        + envelope_headline(os.path.join(out_root, "envelope-puma_ship", "runs.csv"), "kt")
        + " (below) | envelope study |",
        "",
    ]
