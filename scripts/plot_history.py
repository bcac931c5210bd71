#!/usr/bin/python3
"""Plot every probe of a run's history.csv against time, one panel per probe.

    scripts/plot_history.py RUN_FOLDER [--out FILE.png]

Reads RUN_FOLDER/history_joined.csv where a coupled run wrote one (every process's probes side
by side: the coordinator's and each contact process's, a cell left empty where a process has no
row at that time), else RUN_FOLDER/history.csv (the run contract's history), and writes
RUN_FOLDER/history.png unless --out says otherwise. Uses matplotlib from Debian's
python3-matplotlib.
"""
import argparse
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402 - after matplotlib.use("Agg") (no display)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("run_folder")
    parser.add_argument("--out")
    args = parser.parse_args()
    joined = os.path.join(args.run_folder, "history_joined.csv")
    path = joined if os.path.isfile(joined) else os.path.join(args.run_folder, "history.csv")
    try:
        with open(path, newline="") as f:
            rows = list(csv.reader(f))
    except OSError as e:
        print(f"plot_history: error: {path}: {e.strerror}", file=sys.stderr)
        return 2
    if len(rows) < 2 or rows[0][0] != "time":
        print(f"plot_history: error: {path}: expected a header starting with 'time' and data rows", file=sys.stderr)
        return 2
    header, data = rows[0], [r for r in rows[1:] if len(r) == len(rows[0])]
    time = [float(r[0]) for r in data]
    probes = header[1:]
    if not probes:
        print(f"plot_history: {path} has no probe columns; nothing to plot", file=sys.stderr)
        return 0
    fig, axes = plt.subplots(len(probes), 1, sharex=True, figsize=(8, 1.9 * len(probes) + 0.8), squeeze=False)
    for i, name in enumerate(probes):
        ax = axes[i][0]
        # Each probe at the times its process wrote it (empty cells of a joined history skipped).
        points = [(t, float(r[i + 1])) for t, r in zip(time, data) if r[i + 1] != ""]
        ax.plot([p[0] for p in points], [p[1] for p in points], lw=1.0)
        ax.set_ylabel(name)
        ax.grid(True, alpha=0.3)
    axes[-1][0].set_xlabel("time [s]")
    fig.suptitle(os.path.basename(os.path.normpath(args.run_folder)))
    fig.tight_layout()
    out = args.out or os.path.join(args.run_folder, "history.png")
    fig.savefig(out, dpi=110)
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
