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
  modes           the fan plot of a MODES analysis (numerics.smooth.analysis: MODES): each
                  mode's frequency against the spin speed, with the per-rev lines
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
# (This module is the command line, and the only place where a StudyError becomes an exit.)
import argparse
import os
import sys
from studies.common import StudyError, ROOT, Runner, fail
from studies.kinds import STUDIES
from studies.results import results


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
    parser.add_argument(
        "--bin",
        default=os.environ.get("COSIM_BIN_DIR", os.path.join(ROOT, "build", "release", "bin")),
        help="the folder of the built executables the runs use (default: COSIM_BIN_DIR, else build/release/bin)",
    )
    args = parser.parse_args()
    try:
        run(args)
    except StudyError as e:
        print(f"cosim study: error: {e}", file=sys.stderr)
        sys.exit(e.code)


def run(args):
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
