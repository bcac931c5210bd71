#!/usr/bin/python3
"""scripts/cosim rotor: rotors written as scenes, and the generated-rotor study.

  rotor new --out DIR [--topology articulated|teetering|hingeless] [--blades N] [--radius R] ...
        a rotor from your numbers (every field of rotors/spec.py's Rotor: --FIELD VALUE), written
        as a co-simulated scene (DIR/rotor.pbtxt) and its continuous twin
        (DIR/rotor_continuous.pbtxt), in parameters, frames, a pattern and included files; the
        fields you leave out keep Rotor's defaults (a 4-blade articulated rotor, R = 5 m)
  rotor draw --seed S [--count N] --out DIR
        N rotors drawn from physical ranges (seeds S, S+1, …), each in DIR/rotor_SEED/
  rotor sample [--count N] [--seed S] [--out DIR] [--jobs J] [--restart-every K] [--window T] [--topology T]
        draws N rotors, runs each co-simulated and continuous with default numerics, judges the
        pair (rotors/check.py) and writes DIR/runs.csv and DIR/report.md: pass rate by topology,
        blade model and stop model, wall time per rotor, each failure with its scene (a failing
        seed's folder is a scene anyone can run). Every K-th rotor is also restarted from the
        middle of a contact and compared with the run made in one go.
Exit: 0 (sample: every rotor passed), 1 (sample: some failed), 2 bad input.
"""
import argparse
import concurrent.futures
import csv
import dataclasses
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from rotors import check, scene, spec  # noqa: E402 - after sys.path.insert (scripts/)

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def fail(message):
    print(f"cosim rotor: error: {message}", file=sys.stderr)
    sys.exit(2)


def new(argv):
    parser = argparse.ArgumentParser(prog="scripts/cosim rotor new")
    parser.add_argument("--out", required=True)
    fields = {f.name: f for f in dataclasses.fields(spec.Rotor)}
    for name, f in fields.items():
        kind = {bool: lambda v: v.lower() in ("1", "true", "yes"), int: int, float: float}.get(type(f.default), str)
        parser.add_argument(f"--{name.replace('_', '-')}", dest=name, type=kind)
    parser.add_argument("--droop-deg", type=float, help="the droop stop [deg] (instead of --droop in rad)")
    parser.add_argument("--antiflap-deg", type=float, help="the anti-flap stop [deg]")
    args = parser.parse_args(argv)
    rotor = spec.Rotor()
    if args.sections_csv:
        args.sections_csv = os.path.abspath(args.sections_csv)
        if args.blade_model is None:
            args.blade_model = "beam"
    for name in fields:
        value = getattr(args, name)
        if value is not None:
            setattr(rotor, name, value)
    import math

    if args.droop_deg is not None:
        rotor.droop = math.radians(args.droop_deg)
    if args.antiflap_deg is not None:
        rotor.antiflap = math.radians(args.antiflap_deg)
    if args.name is None:
        rotor.name = os.path.basename(os.path.normpath(args.out)) or "rotor"
    problems = rotor.check()
    if problems:
        fail("; ".join(problems))
    a, b = scene.write(rotor, args.out)
    print(f"wrote {a}\n      {b}\nrun them: scripts/cosim run {a} --out {args.out}/run")


def draw(argv):
    parser = argparse.ArgumentParser(prog="scripts/cosim rotor draw")
    parser.add_argument("--seed", type=int, required=True)
    parser.add_argument("--count", type=int, default=1)
    parser.add_argument("--out", required=True)
    args = parser.parse_args(argv)
    for seed in range(args.seed, args.seed + args.count):
        rotor = spec.draw(seed)
        a, _ = scene.write(rotor, os.path.join(args.out, rotor.name))
        print(f"{a}: {rotor.blades}-blade {rotor.topology}, {rotor.blade_model} blades, {rotor.excitation}")


def sample(argv):
    parser = argparse.ArgumentParser(prog="scripts/cosim rotor sample")
    parser.add_argument("--count", type=int, default=300)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default=os.path.join(ROOT, "runs", "rotors"))
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--restart-every", type=int, default=10)
    parser.add_argument("--window", type=float, help="cap each rotor's simulated time [s] (a short sample)")
    parser.add_argument("--topology", choices=spec.TOPOLOGIES, help="draw rotors of this topology only")
    parser.add_argument("--bin", default=os.environ.get("COSIM_BIN_DIR", os.path.join(ROOT, "build", "release", "bin")))
    args = parser.parse_args(argv)
    if args.count < 1 or args.jobs < 1:
        fail("--count and --jobs must be positive")
    os.makedirs(args.out, exist_ok=True)
    folders = []
    for seed in range(args.seed, args.seed + args.count):
        rotor = spec.draw(seed, args.topology)
        if args.window:
            rotor.end_time = min(rotor.end_time, args.window)
        scene.write(rotor, os.path.join(args.out, rotor.name))
        folders.append((seed, os.path.join(args.out, rotor.name)))
    results, t0 = [], time.time()
    with concurrent.futures.ThreadPoolExecutor(args.jobs) as pool:
        futures = {
            pool.submit(
                check.judge, folder, args.bin, args.restart_every > 0 and (seed % args.restart_every) == 0
            ): seed
            for seed, folder in folders
        }
        for n, fut in enumerate(concurrent.futures.as_completed(futures), 1):
            res = fut.result()
            res["seed"] = futures[fut]
            results.append(res)
            left = (time.time() - t0) / n * (len(folders) - n)
            status = "ok" if res["ok"] else "FAILED: " + res["why"]
            print(
                f"[{n}/{len(folders)}, ~{left / 60:.0f} min left] "
                f"{res['name']} {res['topology']} {res['blade_model']} {res['excitation']}: {status}",
                flush=True,
            )
    results.sort(key=lambda r: r["seed"])
    write_report(args.out, results)
    sys.exit(0 if all(r["ok"] for r in results) else 1)


def write_report(out, results):
    keys = sorted({k for r in results for k in r})
    with open(os.path.join(out, "runs.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        w.writerows(results)
    lines = ["# Generated rotors with default numerics", ""]
    passed = sum(r["ok"] for r in results)
    lines.append(f"{passed} of {len(results)} rotors passed (scripts/rotor.py; criteria in scripts/rotors/check.py).")
    lines.append("")

    def table(label, key):
        lines.extend(
            [
                f"| {label} | rotors | passed | mean wall co-simulated [s] | mean wall continuous [s] |",
                "|---|---|---|---|---|",
            ]
        )
        for value in sorted({key(r) for r in results}):
            group = [r for r in results if key(r) == value]
            ok = sum(r["ok"] for r in group)
            wc = sum(r.get("cosim_wall", 0) for r in group) / len(group)
            wt = sum(r.get("twin_wall", 0) for r in group) / len(group)
            lines.append(f"| {value} | {len(group)} | {ok} ({100 * ok / len(group):.0f} %) | {wc:.1f} | {wt:.1f} |")
        lines.append("")

    table("topology", lambda r: r["topology"])
    table("blades", lambda r: r["blade_model"])
    table("tie", lambda r: "rigid" if r["regularization"] == 0 else "regularised")
    table("contact processes", lambda r: r["processes"])
    table("excitation", lambda r: r["excitation"])
    restarts = [r for r in results if "restart_difference" in r]
    if restarts:
        lines.append(
            f"Restarts from the middle of a contact: {len(restarts)}, largest departure from the run made in one go "
            f"{max(r['restart_difference'] for r in restarts):.3g}."
        )
        lines.append("")
    refined = [r for r in results if r.get("twin_refinement", 1) > 1]
    if refined:
        lines.append(
            f"Pairs judged against a refined twin (its stop contacts shorter, rotors/check.py): {len(refined)}, "
            + ", ".join(f"{r['name']} ({r['twin_refinement']}x, {'passed' if r['ok'] else 'failed'})" for r in refined)
            + "."
        )
        lines.append("")
    failed = [r for r in results if not r["ok"]]
    if failed:
        lines.append("## Failures")
        lines.append("")
        for r in failed:
            lines.append(f"- `{r['name']}/` ({r['topology']}, {r['blade_model']}, {r['excitation']}): {r['why']}")
    with open(os.path.join(out, "report.md"), "w") as f:
        f.write("\n".join(lines) + "\n")


def main():
    if len(sys.argv) < 2 or sys.argv[1] in ("-h", "--help", "help"):
        print(__doc__)
        return
    verbs = {"new": new, "draw": draw, "sample": sample}
    if sys.argv[1] not in verbs:
        fail(f"unknown verb '{sys.argv[1]}'; expected new, draw or sample")
    verbs[sys.argv[1]](sys.argv[2:])


if __name__ == "__main__":
    main()
