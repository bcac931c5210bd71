#!/usr/bin/python3
"""The libraries and their folders include only what lies below them.

`interface` is the layer both solvers stand on and includes neither; neither solver includes the
other, so either side can be replaced by another program that reads the same scenario and speaks
the same protocol (docs/design.md, "Architecture: processes and libraries"). Inside each library
the folders are layered, each including only its own files and those of the layers listed before
it: the physics of each concept (forces, beams, elastic bodies, air loads) below the model that
the scenario readers build from them, the model below the integrators, the integrators below the
simulation and the coupling. An include that runs back up a layer fails here, naming the file,
its line and the layers it may include.

Usage: layers_test.py SOURCE_DIR
"""

import os
import re
import sys

# Per library, its folders' layers from the bottom up; folders of one layer do not include
# each other. A library's files outside any folder (its main.cpp) may include every layer.
LAYERS = {
    "smooth_solver": [
        ["constraints"],
        ["linear_algebra", "data"],
        ["forces"],
        ["beam", "elastic"],
        ["aero"],
        ["model"],
        ["integrator", "analysis"],
        ["simulation"],
        ["coupling"],
    ],
    "nonsmooth_solver": [["lcp"], ["model"], ["integrator", "coupling"], ["penalty", "simulation"]],
    # The base (errors, number and echo formatting, bounded reads, whole writes, the folder lock)
    # under the scenario files, the contact law and the visual output; the run contract on them;
    # the coupling channel; the launcher on top.
    "interface": [["base"], ["scenario", "contact", "visual"], ["run"], ["coupling"], ["launcher"]],
}
# The libraries each library may include besides its own folders.
LIBRARIES = {
    "interface": set(),
    "smooth_solver": {"interface"},
    "nonsmooth_solver": {"interface"},
}
INCLUDE = re.compile(r'^\s*#\s*include\s+"([a-z_]+)/([a-z_]+)/')


def check(root):
    """The failures, one line each, and the number of includes checked."""
    failures, checked = [], 0
    for library, allowed in LIBRARIES.items():
        layers = LAYERS.get(library, [])
        level = {folder: k for k, layer in enumerate(layers) for folder in layer}
        for folder, _, names in sorted(os.walk(os.path.join(root, library))):
            for name in sorted(n for n in names if n.endswith((".h", ".cpp"))):
                path = os.path.join(folder, name)
                relative = os.path.relpath(path, root)
                parts = relative.split(os.sep)
                own = parts[1] if len(parts) > 2 else None
                if own is not None and layers and own not in level:
                    failures.append(
                        f"{relative}: folder '{own}' is in no layer of {library} (tests/scripts/layers_test.py)"
                    )
                    continue
                with open(path, encoding="utf-8") as f:
                    for number, line in enumerate(f, 1):
                        match = INCLUDE.match(line)
                        if not match:
                            continue
                        checked += 1
                        target_library, target = match.group(1), match.group(2)
                        where = f"{relative}:{number}: includes {target_library}/{target}/"
                        if target_library != library:
                            if target_library not in allowed:
                                failures.append(f"{where}; {library} may include only {sorted(allowed) or 'itself'}")
                            continue
                        if own is None or not layers or target == own:
                            continue
                        if target not in level:
                            failures.append(f"{where}, a folder in no layer")
                        elif level[target] >= level[own]:
                            below = [f for layer in layers[: level[own]] for f in layer]
                            failures.append(f"{where}, not below '{own}' (it may include {', '.join(below) or 'none'})")
    return failures, checked


def main():
    root = os.path.abspath(sys.argv[1]) if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "../..")
    failures, checked = check(root)
    print(f"layers: {checked} includes between folders and libraries checked")
    for failure in failures:
        print(f"FAIL: {failure}", file=sys.stderr)
    if checked == 0:
        print("FAIL: no include found", file=sys.stderr)
    return 1 if failures or checked == 0 else 0


if __name__ == "__main__":
    sys.exit(main())
