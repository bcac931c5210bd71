#!/usr/bin/python3
"""No Python function is longer than 100 lines.

Why it holds: a study reads as its steps, each a function of its own — validate (the arguments
and the scene's study section), plan (the runs to make), run, measure (the runs' outputs as
numbers) and report (CSV, figures, markdown) — and the other scripts are cut the same way; the
longest function of the tracked sources was 83 lines when this test came in (rotors/spec.py's
draw), the studies' entry points 20 to 60. The C++ has the same kind of rule (.clang-tidy:
functions up to 120 lines); flake8's mccabe bounds the branches (.flake8, max-complexity).

A function's length is its lines from `def` to its last line (ast: end_lineno - lineno + 1; its
decorators not counted), nested functions and methods each measured on their own and counted in
the function holding them too. The files are the tracked ones (`git ls-files '*.py'`, as the lint
gate reads them), else every .py file outside build folders. Fails naming each file, line,
function and length; and if it found no function at all (a test that cannot fail).

Usage: python_size_test.py SOURCE_DIR
"""

import ast
import os
import subprocess
import sys

LIMIT = 100  # lines


def python_files(root):
    """The tracked Python files (git), else every .py file but build outputs."""
    try:
        listed = subprocess.run(
            ["git", "-C", root, "ls-files", "*.py"], check=True, capture_output=True, text=True
        ).stdout.split("\n")
        return sorted(f for f in listed if f)
    except (OSError, subprocess.CalledProcessError):
        files = []
        for base, dirs, names in os.walk(root):
            dirs[:] = [d for d in dirs if d not in (".git", "build", "runs", "__pycache__")]
            files += [os.path.relpath(os.path.join(base, n), root) for n in names if n.endswith(".py")]
        return sorted(files)


def function_lengths(path):
    """[(line, name, length)] of every function and method in a Python file."""
    with open(path, encoding="utf-8") as f:
        tree = ast.parse(f.read(), filename=path)
    return [
        (node.lineno, node.name, node.end_lineno - node.lineno + 1)
        for node in ast.walk(tree)
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
    ]


def main():
    root = os.path.abspath(sys.argv[1]) if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "../..")
    failures, functions, longest = [], 0, (0, "none")
    for relative in python_files(root):
        for line, name, length in function_lengths(os.path.join(root, relative)):
            functions += 1
            longest = max(longest, (length, f"{relative}:{line}: {name}"))
            if length > LIMIT:
                failures.append(
                    f"{relative}:{line}: {name} is {length} lines, over {LIMIT}: cut it into named steps "
                    "(validate, plan, run, measure, report) as scripts/studies does"
                )
    print(f"python size: {functions} functions checked; the longest, {longest[1]}, {longest[0]} lines")
    for failure in failures:
        print(f"FAIL: {failure}", file=sys.stderr)
    if functions == 0:
        print("FAIL: no Python function found", file=sys.stderr)
    return 1 if failures or functions == 0 else 0


if __name__ == "__main__":
    sys.exit(main())
