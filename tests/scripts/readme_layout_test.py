"""The README's Layout table is the map of the source tree: every folder it names exists, and
every folder a contributor meets (the top level, and the first level of the libraries, the
scripts, the tests and the docs) is in it. The README stays an entry page (under 10,000
characters; the user guide and the changelog hold the rest). Fails naming the folder."""

import os
import re
import subprocess
import sys

ROOT = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", "..")
DESCRIBED_BELOW = ["interface", "nonsmooth_solver", "smooth_solver", "scripts", "tests", "docs"]


def tracked_folders(root):
    """The folders holding tracked files (git), else every folder but build outputs."""
    try:
        files = subprocess.run(
            ["git", "-C", root, "ls-files"], check=True, capture_output=True, text=True
        ).stdout.split("\n")
    except (OSError, subprocess.CalledProcessError):
        files = []
        for base, dirs, names in os.walk(root):
            dirs[:] = [d for d in dirs if d not in (".git", "build", "runs", "__pycache__")]
            files += [os.path.relpath(os.path.join(base, n), root) for n in names]
    folders = set()
    for f in files:
        parts = f.split("/")[:-1]
        for depth in range(1, min(len(parts), 2) + 1):
            folders.add("/".join(parts[:depth]))
    return folders


def layout_folders(readme):
    section = readme.split("\n## Layout\n", 1)
    if len(section) != 2:
        raise SystemExit("README.md has no '## Layout' section")
    named = set()
    for line in section[1].split("\n"):
        if not line.startswith("| `"):
            continue
        first = line.split("|")[1]
        named.update(m.rstrip("/") for m in re.findall(r"`([^`]+/)`", first))
    return named


def main():
    with open(os.path.join(ROOT, "README.md"), encoding="utf-8") as f:
        readme = f.read()
    problems = []
    if len(readme) >= 10000:
        problems.append(f"README.md has {len(readme)} characters; an entry page stays under 10,000")
    named = layout_folders(readme)
    for folder in sorted(named):
        if not os.path.isdir(os.path.join(ROOT, folder)):
            problems.append(f"the Layout table names `{folder}/`, which does not exist")
    for folder in sorted(tracked_folders(ROOT)):
        top = folder.split("/")[0]
        required = "/" not in folder or top in DESCRIBED_BELOW
        if required and folder not in named:
            problems.append(f"`{folder}/` is not in README.md's Layout table")
    for p in problems:
        print(p)
    sys.exit(1 if problems else 0)


if __name__ == "__main__":
    main()
