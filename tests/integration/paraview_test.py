#!/usr/bin/python3
"""scripts/paraview_scene.py under Debian's ParaView (pvbatch in xvfb-run), on a coupled run.

Why these hold: the small rotor's blades rest on their co-simulated droop stops at t = 0.2 s,
so the snapshot holds the structure (bodies coloured by kind: blue-green) and planes and nodes
in contact (red); the state file is ParaView's XML naming the run's scene.pvd, which `paraview
--state` reopens; a folder without visual output is refused with exit 2 and the reason.
Registered by tests/CMakeLists.txt only where pvbatch and xvfb-run are installed.

Usage: paraview_test.py BIN_DIR SOURCE_DIR WORK_DIR
"""
import os
import shutil
import subprocess
import sys
import unittest

import matplotlib.image

BIN, SOURCE, WORK = sys.argv[1:4]
SCRIPT = os.path.join(SOURCE, "scripts", "paraview_scene.py")
XVFB = ["xvfb-run", "-a", "-s", "-screen 0 1280x1024x24", "pvbatch", SCRIPT]


class ParaViewScene(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        shutil.rmtree(WORK, ignore_errors=True)
        cls.out = os.path.join(WORK, "rotor")
        subprocess.run(
            [
                os.path.join(BIN, "cosim_launch"),
                os.path.join(SOURCE, "scenarios/small_rotor/anti_flap_impact.pbtxt"),
                "--out",
                cls.out,
                "--set",
                "numerics.end_time=0.3",
                "--set",
                "output.visual.every=50",
            ],
            check=True,
            capture_output=True,
        )

    def test_snapshot_and_state(self):
        p = subprocess.run(XVFB + [self.out, "--time", "0.2", "--size", "640", "400"], capture_output=True, text=True)
        self.assertEqual(p.returncode, 0, p.stdout + p.stderr)
        self.assertIn("at t = 0.2 s (7 frames)", p.stdout)
        image = matplotlib.image.imread(os.path.join(self.out, "paraview", "snapshot.png"))
        self.assertEqual(image.shape[:2], (400, 640))
        r, g, b = image[..., 0], image[..., 1], image[..., 2]
        self.assertGreater(int(((b - r) > 0.2).sum()), 500)  # the blades (kind colours)
        self.assertGreater(int(((r - g) > 0.15).sum()), 50)  # planes and nodes in contact
        with open(os.path.join(self.out, "paraview", "scene.pvsm")) as f:
            state = f.read()
        self.assertTrue(
            state.startswith("<GenericParaViewApplication>") and "<ServerManagerState" in state, state[:200]
        )
        self.assertTrue(os.path.abspath(os.path.join(self.out, "scene.pvd")) in state, "the state names no scene.pvd")

    def test_no_visual_output_is_refused(self):
        bare = os.path.join(WORK, "bare")
        os.makedirs(bare, exist_ok=True)
        p = subprocess.run(XVFB + [bare], capture_output=True, text=True)
        self.assertEqual(p.returncode, 2, p.stdout + p.stderr)
        self.assertIn("has no scene.pvd or visual.pvd", p.stderr)


if __name__ == "__main__":
    unittest.main(argv=sys.argv[:1])
