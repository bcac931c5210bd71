#!/usr/bin/python3
"""Visual output read back with meshio (Debian's python3-meshio), against the runs' histories.

Why these hold: a frame is drawn from the same state as the history row of the same time, so a
body's origin, a contact node and a hex27 node's displacement must be the probes' values to
round-off (17 digits written); a hex27 element's reference nodes must sit where VTK's
tri-quadratic hexahedron puts them (edge nodes at the middle of their corners, face nodes at
the centre of their four, the centre at the mean of the eight: VTK's documented numbering,
written out here independently of the writer's table) with a positive volume; the beam ribbon
has one section per node; and the series' index (visual.pvd, scene.pvd) lists every frame.

Usage: visual_test.py BIN_DIR SOURCE_DIR WORK_DIR
"""
import json
import os
import subprocess
import sys
import unittest
import xml.etree.ElementTree as ET

import meshio
import numpy as np

BIN, SOURCE, WORK = sys.argv[1:4]
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
# VTK_TRIQUADRATIC_HEXAHEDRON: nodes 8-19 on the edges, 20-25 on the faces x-, x+, y-, y+, z-, z+.
EDGES = [(0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4), (0, 4), (1, 5), (2, 6), (3, 7)]
FACES = [(0, 3, 4, 7), (1, 2, 5, 6), (0, 1, 4, 5), (2, 3, 6, 7), (0, 1, 2, 3), (4, 5, 6, 7)]


def launch(name, scenario, *sets):
    """(output folder, exit code, stderr) of a run of `scenario` into WORK/name."""
    out = os.path.join(WORK, name)
    args = [os.path.join(BIN, "cosim_launch"), os.path.join(SOURCE, scenario), "--out", out]
    for s in sets:
        args += ["--set", s]
    p = subprocess.run(args, capture_output=True, text=True)
    return out, p.returncode, p.stderr


def run(name, scenario, *sets):
    out, code, stderr = launch(name, scenario, *sets)
    if code != 0:
        raise AssertionError(f"{scenario}: exit {code}: {stderr}")
    return out


def series(pvd):
    root = ET.parse(pvd).getroot()
    return [(float(d.get("timestep")), d.get("file"), int(d.get("part"))) for d in root.iter("DataSet")]


def history(folder):
    return np.genfromtxt(os.path.join(folder, "history.csv"), delimiter=",", names=True)


def cells_of(mesh, kind):
    """(cell type, connectivity) of the cells of one kind."""
    out = []
    for block, kinds in zip(mesh.cells, mesh.cell_data["kind"]):
        for row, k in zip(block.data, kinds):
            if k == KIND[kind]:
                out.append((block.type, row))
    return out


class Visual(unittest.TestCase):
    def test_coupled_drop_body_node_floor_and_tie(self):
        # Every 5th step to t = 0.35 s: the first impact (t = 0.319 s) is among the frames.
        out = run("tied_drop", "scenarios/tied_drop.pbtxt", "output.visual.every=5", "numerics.end_time=0.35")
        smooth, contact = series(os.path.join(out, "visual.pvd")), series(os.path.join(out, "contacts", "visual.pvd"))
        self.assertEqual(len(smooth), 71)
        self.assertEqual(len(contact), 71)
        scene = series(os.path.join(out, "scene.pvd"))
        self.assertEqual(len(scene), 142)
        self.assertEqual({part for _, _, part in scene}, {0, 1})
        h, hc = history(out), history(os.path.join(out, "contacts"))
        touched = 0
        for (t, file, _), (tc, file_c, _) in zip(smooth, contact):
            self.assertEqual(t, tc)
            row = np.argmin(abs(h["time"] - t))
            mesh = meshio.read(os.path.join(out, file))
            self.assertAlmostEqual(float(mesh.field_data["TimeValue"][0]), t, places=12)
            axes = cells_of(mesh, "body_axis")
            self.assertEqual(len(axes), 3)  # one body, three axes from its origin
            box = [c for kind, c in cells_of(mesh, "body_shape") if kind == "hexahedron"]
            self.assertEqual(len(box), 1)  # its box, centred on the origin (its only point is the tie's, there)
            np.testing.assert_allclose(mesh.points[box[0]].mean(axis=0), mesh.points[axes[0][1][0]], atol=1e-12)
            self.assertAlmostEqual(mesh.points[axes[0][1][0]][2], h["body_z"][row], delta=1e-12)
            tie = cells_of(mesh, "tie")
            self.assertEqual(len(tie), 1)
            cm = meshio.read(os.path.join(out, "contacts", file_c))
            nodes = cells_of(cm, "node")
            self.assertEqual(len(nodes), 1)
            self.assertAlmostEqual(
                cm.points[nodes[0][1][0]][2], hc["node_z"][np.argmin(abs(hc["time"] - t))], delta=1e-12
            )
            # The tie ends where the contact process put the node (the imposed coordinates).
            self.assertAlmostEqual(mesh.points[tie[0][1][1]][2], cm.points[nodes[0][1][0]][2], delta=1e-9)
            self.assertEqual(len(cells_of(cm, "obstacle")), 1)
            contact_flags = [
                v
                for b, k in zip(cm.cell_data["in_contact"], cm.cell_data["kind"])
                for v, kk in zip(b, k)
                if kk == KIND["node"]
            ]
            row_c = np.argmin(abs(hc["time"] - t))
            # In contact exactly when the step's impulse is non-zero or the gap closed.
            self.assertEqual(contact_flags[0], int(hc["impulse"][row_c] != 0.0 or hc["gap"][row_c] <= 0.0), t)
            touched += contact_flags[0]
        with open(os.path.join(out, "contacts", "visual", "legend.csv")) as f:
            self.assertIn("6,0,node", f.read())
        self.assertGreaterEqual(touched, 1)  # the impact was drawn

    def test_each_contact_process_draws_the_planes_of_its_own_nodes_only(self):
        # The co-simulated Puma: four contact processes, each with one blade's pad against that
        # blade's droop and anti-flap planes. Each draws those two planes and no other blade's
        # (each once drew all eight, six of them as 0.2 m squares at the hub).
        out = run(
            "puma_planes", "scenarios/puma/engage_disengage.pbtxt", "output.visual.every=2", "numerics.end_time=0.004"
        )
        for k in range(1, 5):
            folder = os.path.join(out, f"stops{k}")
            frames = series(os.path.join(folder, "visual.pvd"))
            self.assertEqual(len(frames), 3)
            for _, file, _ in frames:
                self.assertEqual(len(cells_of(meshio.read(os.path.join(folder, file)), "obstacle")), 2, (k, file))
            with open(os.path.join(folder, "visual", "legend.csv")) as f:
                names = {line.strip().split(",")[2] for line in f if line.startswith("7,")}
            self.assertEqual(names, {f"blade{k}_droop", f"blade{k}_antiflap"})

    def test_hex27_blade_nodes_in_vtk_order_with_displacement_and_stress(self):
        out = run("spinning_blade", "scenarios/spinning_blade.pbtxt", "numerics.end_time=0.1", "output.visual.every=10")
        frames = series(os.path.join(out, "visual.pvd"))
        self.assertEqual(len(frames), 6)
        h = history(out)
        reference = None
        for t, file, _ in frames:
            mesh = meshio.read(os.path.join(out, file))
            solids = cells_of(mesh, "solid")
            self.assertGreater(len(solids), 0)
            self.assertTrue(all(kind == "hexahedron27" for kind, _ in solids))
            solid_points = np.unique(np.concatenate([c for _, c in solids]))
            d = mesh.point_data["displacement"][solid_points]
            X = mesh.points[solid_points] - d  # reference positions: the same in every frame
            if reference is None:
                reference = X
                for _, c in solids:
                    p = (mesh.points - mesh.point_data["displacement"])[c]
                    for k, (a, b) in enumerate(EDGES):
                        np.testing.assert_allclose(p[8 + k], 0.5 * (p[a] + p[b]), atol=1e-12)
                    for k, face in enumerate(FACES):
                        np.testing.assert_allclose(p[20 + k], p[list(face)].mean(axis=0), atol=1e-12)
                    np.testing.assert_allclose(p[26], p[:8].mean(axis=0), atol=1e-12)
                    self.assertGreater(np.linalg.det(np.array([p[1] - p[0], p[3] - p[0], p[4] - p[0]])), 0.0)
            else:
                np.testing.assert_allclose(X, reference, atol=1e-9)
            row = np.argmin(abs(h["time"] - t))
            tip = np.array([h["tip_x"][row], h["tip_y"][row], h["tip_z"][row]])
            self.assertLess(
                np.min(np.linalg.norm(d - tip, axis=1)), 1e-12, f"t = {t}: no node with the tip's displacement"
            )
            stress = [
                s
                for b, k in zip(mesh.cell_data["von_mises"], mesh.cell_data["kind"])
                for s, kk in zip(b, k)
                if kk == KIND["solid"]
            ]
            if t > 0:
                self.assertGreater(max(stress), 0.0)  # spinning up: stressed
            else:
                self.assertLess(max(stress), 1e-3)  # the reference configuration: no stress

    def test_continuous_contact_point_and_plane_in_contact_while_the_gap_is_closed(self):
        # pendulum_stop_continuous: the tip body against the stop plane x = 0 (Hunt–Crossley):
        # the first impact near t = 0.51 s lasts a few steps; drawn every step around it.
        out = run(
            "pendulum_continuous",
            "scenarios/pendulum_stop_continuous.pbtxt",
            "numerics.end_time=0.53",
            "output.visual.every=10",
            "output.every=10",
        )
        h = history(out)
        closed = 0
        for t, file, _ in series(os.path.join(out, "visual.pvd")):
            mesh = meshio.read(os.path.join(out, file))
            ((_, point),) = cells_of(mesh, "node")
            ((_, plane),) = cells_of(mesh, "obstacle")
            flags = {
                k: v for b, kinds in zip(mesh.cell_data["in_contact"], mesh.cell_data["kind"]) for v, k in zip(b, kinds)
            }
            tip_x = h["tip_x"][np.argmin(abs(h["time"] - t))]
            self.assertAlmostEqual(mesh.points[point[0]][0], tip_x, delta=1e-12)
            self.assertEqual(flags[KIND["node"]], int(tip_x <= 0.0), t)
            self.assertEqual(flags[KIND["obstacle"]], flags[KIND["node"]])
            np.testing.assert_allclose(mesh.points[plane][:, 0], 0.0, atol=1e-12)  # the plane x = 0
            closed += flags[KIND["node"]]
        self.assertGreaterEqual(closed, 1)

    def test_a_run_without_visual_output_leaves_none_of_an_earlier_runs(self):
        out = run("rerun", "scenarios/tied_drop.pbtxt", "output.visual.every=100", "numerics.end_time=0.2")
        self.assertTrue(os.path.isfile(os.path.join(out, "scene.pvd")))
        run("rerun", "scenarios/tied_drop.pbtxt", "numerics.end_time=0.2")
        for stale in ("scene.pvd", "visual.pvd", "visual", "contacts/visual.pvd", "contacts/visual"):
            self.assertFalse(os.path.exists(os.path.join(out, stale)), stale)

    def test_beam_as_polyline_and_ribbon(self):
        out = run("spin_up", "scenarios/beams/spin_up.pbtxt", "numerics.end_time=0.02", "output.visual.every=5")
        frames = series(os.path.join(out, "visual.pvd"))
        self.assertEqual(len(frames), 3)
        with open(os.path.join(out, frames[-1][1]), "rb") as f:
            self.assertIn(b'format="binary"', f.read())  # binary arrays, base64 inline
        mesh = meshio.read(os.path.join(out, frames[-1][1]))
        axis = cells_of(mesh, "beam_axis")
        nodes = len(axis) + 1
        self.assertEqual(nodes, 21)  # 10 quadratic elements: n0 … n20, joined by 20 lines
        self.assertTrue(all(kind == "line" for kind, _ in axis))
        sections = cells_of(mesh, "beam_section")
        self.assertEqual(sum(1 for kind, _ in sections if kind == "line"), 2 * nodes)  # chordwise and flapwise
        self.assertEqual(sum(1 for kind, _ in sections if kind == "quad"), nodes - 1)
        h = history(out)
        # The tip node's radial position in the hub's frame is its distance along the hub's x axis
        # at this small hub angle: within the hub's rotation over 0.02 s of the history's.
        tip = mesh.points[axis[-1][1][1]]
        self.assertAlmostEqual(float(np.hypot(tip[0], tip[1])), float(h["tip_radial"][-1]), delta=1e-3)

    def test_render_snapshot_box_holds_a_frame_the_animation_leaves_out(self):
        # The bouncing ball's first fall: at 1 m at t = 0, 1 − g t²/2 = 0.007 m at 0.45 s. An
        # animation of one frame (the first) and the snapshot at 0.45 s: the box is drawn from
        # both (once: from the animation's frames only, so the snapshot's ball near the
        # floor fell outside a box around 1 m).
        out = run("render_ball", "scenarios/bouncing_ball.pbtxt", "numerics.end_time=0.5", "output.visual.every=10")
        p = subprocess.run(
            ["/usr/bin/python3", os.path.join(SOURCE, "scripts", "render.py"), out, "--frames", "1", "--time", "0.45"],
            capture_output=True,
            text=True,
        )
        self.assertEqual(p.returncode, 0, p.stderr)
        z = p.stderr.split("z [")[1].split("]")[0].split(",")
        self.assertLess(float(z[0]), 0.007, p.stderr)
        self.assertGreater(float(z[1]), 1.0, p.stderr)
        self.assertTrue(os.path.isfile(os.path.join(out, "render", "snapshot.png")))

    def test_every_frame_of_every_process_of_every_shipped_scene_reads_back(self):
        # Each scene the project ships, two steps with a frame at each: every .vtu of every
        # process opens with meshio, with all its arrays (meshio 5.0 skips an array it cannot
        # make sense of with a printed warning only, so their sizes are checked here), and the
        # rotor generator's teetering rotor whose one contact process carries both yoke pads (whose
        # frames meshio could not open: its appended raw block was out of the XML's order).
        scenes = []
        for folder, _, files in os.walk(os.path.join(SOURCE, "scenarios")):
            for name in sorted(files):
                path = os.path.join(folder, name)
                if not name.endswith(".pbtxt"):
                    continue
                with open(path) as f:
                    if any(line.startswith("numerics") for line in f):
                        scenes.append(os.path.relpath(path, SOURCE))
        scenes.append("tests/data/rotors/teetering_rigid_settled_gust/rotor.pbtxt")
        self.assertGreater(len(scenes), 40)
        frames = ran = 0
        for i, scenario in enumerate(sorted(scenes)):
            p = subprocess.run(
                [os.path.join(BIN, "cosim_launch"), os.path.join(SOURCE, scenario), "--print-scenario"],
                capture_output=True,
                text=True,
            )
            self.assertEqual(p.returncode, 0, (scenario, p.stderr))
            numerics = json.loads(p.stdout)["numerics"]
            end = numerics.get("start_time", 0.0) + 2 * numerics["step"]
            # (A hard case meant to be refused or to fail still leaves the frames of its accepted
            # steps, which must open too.)
            out, code, _ = launch(f"shipped_{i}", scenario, "output.visual.every=1", f"numerics.end_time={end!r}")
            files = [os.path.join(d, f) for d, _, fs in os.walk(out) for f in fs if f.endswith(".vtu")]
            if code == 0:
                self.assertGreater(len(files), 0, scenario)
                ran += 1
            meshes = {}
            for file in files:
                try:
                    mesh = meshes[file] = meshio.read(file)
                except Exception as e:  # noqa: BLE001 (which file, with meshio's own error)
                    raise AssertionError(f"{scenario}: meshio cannot read {file}: {e!r}") from e
                n = len(mesh.points)
                cells = sum(len(block.data) for block in mesh.cells)
                self.assertEqual(mesh.point_data["displacement"].shape, (n, 3), file)
                for name in ("kind", "entity", "in_contact", "von_mises"):
                    self.assertEqual(sum(len(b) for b in mesh.cell_data[name]), cells, (file, name))
                frames += 1
            if scenario.startswith("tests/data/rotors"):
                contact = [f for f in files if os.sep + "stops" + os.sep in f]
                self.assertGreater(len(contact), 0)
                for file in contact:
                    self.assertEqual(len(cells_of(meshes[file], "node")), 2, file)  # both pads
        self.assertGreater(ran, 40)
        print(f"{len(scenes)} scenes ({ran} ran to their end), {frames} frames read back", file=sys.stderr)

    def test_plots_use_the_python_the_setup_equipped_whatever_is_first_on_path(self):
        # A `python3` first on PATH without matplotlib (a user's virtualenv): `scripts/cosim plot`
        # and the script run directly both take /usr/bin/python3, whose packages the setup installs.
        # (plot_history.py ran `env python3` and failed there.)
        out = run("plot_ball", "scenarios/bouncing_ball.pbtxt", "numerics.end_time=0.05")
        fake = os.path.join(WORK, "fake_bin")
        os.makedirs(fake, exist_ok=True)
        with open(os.path.join(fake, "python3"), "w") as f:
            f.write("#!/bin/sh\necho 'ModuleNotFoundError: No module named matplotlib' >&2\nexit 1\n")
        os.chmod(os.path.join(fake, "python3"), 0o755)
        env = dict(os.environ, PATH=fake + os.pathsep + os.environ["PATH"])
        for command in (
            [os.path.join(SOURCE, "scripts", "cosim"), "plot", out],
            [os.path.join(SOURCE, "scripts", "plot_history.py"), out],
        ):
            png = os.path.join(out, "history.png")
            if os.path.exists(png):
                os.remove(png)
            p = subprocess.run(command, capture_output=True, text=True, env=env)
            self.assertEqual(p.returncode, 0, (command, p.stderr))
            self.assertTrue(os.path.isfile(png), command)


if __name__ == "__main__":
    unittest.main(argv=sys.argv[:1], verbosity=2)
