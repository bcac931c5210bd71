#!/usr/bin/python3
"""Pictures of a run's visual output: scripts/cosim render RUN [options].

RUN is a run's output folder written with `output { visual { every: N } }` (or
`--set output.visual.every=N`): its scene.pvd (a coupled run: every process) or visual.pvd.
Writes RUN/render/snapshot.png (one frame, 3-D) and RUN/render/animation.gif (the series),
read with meshio and drawn with matplotlib:
  rigid bodies   their axes (x red, y green, z blue), grey lines to their joints and their box
  beams          the node line (dark blue) and the chordwise ribbon (light blue)
  hex27 bodies   the elements' edges coloured by von Mises stress
  ties           dashed orange lines from the body point to its contact node
  contact nodes  dots, red while in contact
  stop planes    translucent squares, red while in contact
Options: --time T (the snapshot's time; default the last frame), --frames N (at most N frames
in the animation, evenly spread; default 60), --view iso|top|side|front, --fps F, --title.
"""
import argparse
import os
import sys
import xml.etree.ElementTree as ET

import matplotlib
import meshio
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402 - after matplotlib.use("Agg") (no display)
from matplotlib import animation  # noqa: E402 - after matplotlib.use("Agg") (no display)
from mpl_toolkits.mplot3d.art3d import (  # noqa: E402 - after matplotlib.use("Agg") (no display)
    Line3DCollection,
    Poly3DCollection,
)

KIND = {
    "body_axis": 0,
    "body_shape": 1,
    "beam_axis": 2,
    "beam_section": 3,
    "solid": 4,
    "tie": 5,
    "node": 6,
    "obstacle": 7,
}
VIEWS = {"iso": (25, -60), "top": (90, -90), "side": (0, -90), "front": (0, 0)}
HEX_EDGES = [(0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4), (0, 4), (1, 5), (2, 6), (3, 7)]


def fail(message, code=2):
    print(f"cosim render: error: {message}", file=sys.stderr)
    sys.exit(code)


def read_series(run):
    """[(time, [vtu paths of that time])] from scene.pvd or visual.pvd."""
    for name in ("scene.pvd", "visual.pvd"):
        index = os.path.join(run, name)
        if os.path.isfile(index):
            break
    else:
        fail(f"{run}: no scene.pvd or visual.pvd (run it with --set output.visual.every=N)")
    try:
        root = ET.parse(index).getroot()
    except ET.ParseError as e:
        fail(f"{index}: not a readable .pvd: {e}")
    frames = {}
    for d in root.iter("DataSet"):
        frames.setdefault(float(d.get("timestep")), []).append(os.path.join(run, d.get("file")))
    if not frames:
        fail(f"{index}: no frames")
    return sorted(frames.items())


class Frame:
    """One time's geometry from every part, as segments and polygons per kind."""

    def __init__(self, paths):
        self.lines = {k: [] for k in KIND}
        self.quads = {"beam_section": [], "obstacle": []}
        self.quad_contact = []
        self.solid_edges, self.solid_stress = [], []
        self.nodes, self.node_contact = [], []
        self.axis_colour = []
        for path in paths:
            mesh = meshio.read(path)
            kind = mesh.cell_data["kind"]
            contact = mesh.cell_data["in_contact"]
            stress = mesh.cell_data["von_mises"]
            for block, kinds, contacts, stresses in zip(mesh.cells, kind, contact, stress):
                pts = mesh.points[block.data]
                for cell, k, c, s in zip(pts, kinds, contacts, stresses):
                    if block.type == "line":
                        name = [n for n, v in KIND.items() if v == k][0]
                        self.lines[name].append(cell)
                        if k == KIND["body_axis"]:
                            self.axis_colour.append("rgb"[len(self.axis_colour) % 3])
                    elif block.type == "quad":
                        if k == KIND["obstacle"]:
                            self.quads["obstacle"].append(cell)
                            self.quad_contact.append(c)
                        else:
                            self.quads["beam_section"].append(cell)
                    elif block.type == "hexahedron":  # a rigid body's box
                        for a, b in HEX_EDGES:
                            self.lines["body_shape"].append(cell[[a, b]])
                    elif block.type == "hexahedron27":
                        for a, b in HEX_EDGES:
                            self.solid_edges.append(cell[[a, b]])
                            self.solid_stress.append(s)
                    elif block.type == "vertex":
                        self.nodes.append(cell[0])
                        self.node_contact.append(c)

    def points(self):
        chunks = [np.reshape(v, (-1, 3)) for v in self.lines.values() if v]
        chunks += [np.reshape(self.quads["beam_section"], (-1, 3))] if self.quads["beam_section"] else []
        chunks += [np.reshape(self.solid_edges, (-1, 3))] if self.solid_edges else []
        chunks += [np.reshape(self.nodes, (-1, 3))] if self.nodes else []
        return np.concatenate(chunks) if chunks else np.zeros((1, 3))


def bounds(frames):
    """Limits over every frame, and the box's aspect: true scale, except that an axis spanning
    less than a third of the largest is drawn a third as long (a rotor's flapping: the
    exaggeration is in the title)."""
    pts = np.concatenate([f.points() for f in frames])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    span = np.maximum(hi - lo, 1e-3 * max((hi - lo).max(), 1e-3))
    centre = 0.5 * (lo + hi)
    lo, hi = centre - 0.55 * span, centre + 0.55 * span
    aspect = np.maximum(span, span.max() / 3.0)
    return lo, hi, aspect, aspect / span


def draw(ax, frame, limits, view, time, stress_max, title):
    ax.clear()
    lo, hi, aspect, stretch = limits
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect(tuple(aspect))
    stretched = ", ".join(f"{a} ×{k:.3g}" for a, k in zip("xyz", stretch) if k > 1.0 + 1e-9)
    ax.view_init(*VIEWS[view])
    ax.set_xlabel("x [m]", fontsize=7)
    ax.set_ylabel("y [m]", fontsize=7)
    ax.set_zlabel("z [m]", fontsize=7)
    ax.tick_params(labelsize=6)
    if frame.quads["obstacle"]:
        colours = ["red" if c else "grey" for c in frame.quad_contact]
        ax.add_collection3d(
            Poly3DCollection(frame.quads["obstacle"], facecolors=colours, alpha=0.25, edgecolors="none")
        )
    if frame.quads["beam_section"]:
        ax.add_collection3d(
            Poly3DCollection(
                frame.quads["beam_section"],
                facecolors="lightsteelblue",
                alpha=0.8,
                edgecolors="steelblue",
                linewidths=0.3,
            )
        )
    styles = {
        "body_shape": dict(colors="0.45", linewidths=1.2),
        "beam_axis": dict(colors="navy", linewidths=1.0),
        "tie": dict(colors="darkorange", linewidths=1.0, linestyles="dashed"),
    }
    for kind, style in styles.items():
        if frame.lines[kind]:
            ax.add_collection3d(Line3DCollection(frame.lines[kind], **style))
    if frame.lines["body_axis"]:
        ax.add_collection3d(Line3DCollection(frame.lines["body_axis"], colors=frame.axis_colour, linewidths=0.8))
    if frame.solid_edges:
        cmap = plt.get_cmap("viridis")
        ax.add_collection3d(
            Line3DCollection(frame.solid_edges, colors=cmap(np.array(frame.solid_stress) / stress_max), linewidths=0.6)
        )
    if frame.nodes:
        nodes = np.array(frame.nodes)
        ax.scatter(
            nodes[:, 0],
            nodes[:, 1],
            nodes[:, 2],
            s=12,
            c=["red" if c else "black" for c in frame.node_contact],
            depthshade=False,
        )
    ax.set_title(f"{title}   t = {time:.3f} s" + (f"\n(drawn stretched: {stretched})" if stretched else ""), fontsize=9)


def main():
    parser = argparse.ArgumentParser(
        prog="scripts/cosim render", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("run", help="a run's output folder with visual output")
    parser.add_argument("--time", type=float, help="the snapshot's time [s] (default: the last frame)")
    parser.add_argument("--frames", type=int, default=60, help="frames of the animation, at most (default 60)")
    parser.add_argument("--view", choices=list(VIEWS), default="iso")
    parser.add_argument("--fps", type=float, default=10.0)
    parser.add_argument("--out", help="output folder (default RUN/render)")
    parser.add_argument("--title", help="the pictures' title (default: the run folder's name)")
    args = parser.parse_args()
    if not os.path.isdir(args.run):
        fail(f"{args.run}: no such folder")
    if args.frames < 1 or not args.fps > 0:
        fail(f"--frames {args.frames}, --fps {args.fps}: expected positive numbers")
    series = read_series(args.run)
    out = args.out or os.path.join(args.run, "render")
    os.makedirs(out, exist_ok=True)
    picks = np.unique(np.linspace(0, len(series) - 1, min(args.frames, len(series))).round().astype(int))
    frames = [Frame(series[i][1]) for i in picks]
    times = [series[i][0] for i in picks]
    title = args.title or os.path.basename(os.path.normpath(args.run))
    # Snapshot: any frame of the series, not only the animation's, so the box holds it too.
    if args.time is None:
        shot, shot_time = frames[-1], times[-1]
    else:
        k = int(np.argmin([abs(t - args.time) for t, _ in series]))
        shot, shot_time = Frame(series[k][1]), series[k][0]
    limits = bounds(frames + [shot])
    stress_max = max([max(f.solid_stress) for f in frames + [shot] if f.solid_stress] + [1e-30])
    fig = plt.figure(figsize=(6.4, 5.6))
    ax = fig.add_subplot(projection="3d")
    draw(ax, shot, limits, args.view, shot_time, stress_max, title)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "snapshot.png"), dpi=120)

    # Animation.
    def update(i):
        draw(ax, frames[i], limits, args.view, times[i], stress_max, title)
        return []

    movie = animation.FuncAnimation(fig, update, frames=len(frames), blit=False)
    movie.save(os.path.join(out, "animation.gif"), writer=animation.PillowWriter(fps=args.fps), dpi=80)
    plt.close(fig)
    box = ", ".join(f"{a} [{lo:.6g}, {hi:.6g}]" for a, lo, hi in zip("xyz", limits[0], limits[1]))
    print(
        f"cosim render: {os.path.join(out, 'snapshot.png')} (t = {shot_time:g} s), "
        f"{os.path.join(out, 'animation.gif')} ({len(frames)} frames of {len(series)}); box {box} m",
        file=sys.stderr,
    )


if __name__ == "__main__":
    main()
