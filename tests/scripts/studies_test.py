#!/usr/bin/python3
"""Unit tests of the studies' pure functions (scripts/studies): each says why its answer holds.
Run by ctest (Studies.PureFunctions) or directly: tests/scripts/studies_test.py."""
import math
import os
import sys
import tempfile
import time
import unittest

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scripts"))
from studies.common import (  # noqa: E402 - after sys.path.insert (scripts/)
    ROOT,
    Reference,
    Run,
    StudyError,
    analytic,
    contact_episodes,
    every_for,
    failures_section,
    fitted_order,
    fmt,
    halving_steps,
    probe_error,
    record,
    same_overrides,
)
from studies.compare import compare_measure  # noqa: E402 - after sys.path.insert (scripts/)
from studies.coupling import relaxation_sets  # noqa: E402 - after sys.path.insert (scripts/)
from studies.envelope import axis_sets, unsafe_points  # noqa: E402 - after sys.path.insert (scripts/)
from studies.results import (  # noqa: E402 - after sys.path.insert (scripts/)
    contents,
    entry_heading,
    envelope_headline,
    headline_rows,
)


class Common(unittest.TestCase):
    def test_root_is_the_repository(self):
        # The package sits two folders below the root: the default output and binary folders hang on it.
        self.assertTrue(os.path.isfile(os.path.join(ROOT, "CMakeLists.txt")))
        self.assertTrue(os.path.isdir(os.path.join(ROOT, "scenarios")))

    def test_fitted_order_of_exact_power_laws(self):
        # e = C h^p gives the slope p in log-log whatever C; errors at round-off are left out.
        steps = [0.1 / 2**i for i in range(5)]
        self.assertAlmostEqual(fitted_order(steps, [3.0 * h**2 for h in steps]), 2.0, places=12)
        self.assertAlmostEqual(fitted_order(steps, [0.5 * h for h in steps]), 1.0, places=12)
        self.assertAlmostEqual(fitted_order(steps, [h**2 for h in steps[:-1]] + [1e-16]), 2.0, places=12)
        self.assertTrue(math.isnan(fitted_order(steps[:1], [1e-3])))  # one point: no slope

    def test_analytic_reference_and_its_refusals(self):
        # math's names and t are all an expression sees; a bad one is the user's input error (exit 2).
        values = analytic("cos(2*pi*t)", [0.0, 0.25, 0.5], "study.references[x]")
        np.testing.assert_allclose(values, [1.0, 0.0, -1.0], atol=1e-15)
        with self.assertRaises(StudyError) as bad:
            analytic("cos(", [0.0], "study.references[x]")
        self.assertEqual(bad.exception.code, 2)
        self.assertIn("study.references[x]", str(bad.exception))
        with self.assertRaises(StudyError) as fails:
            analytic("1/t", [0.0], "study.references[y]")
        self.assertIn("fails at t = 0.0", str(fails.exception))
        with self.assertRaises(StudyError):
            analytic("__import__('os')", [0.0], "w")  # no builtins

    def test_probe_error_against_an_analytic_reference(self):
        # MAX: the largest deviation after error_from; END: the last sample's.
        t = np.array([0.0, 0.5, 1.0])
        history = {"x": (t, np.array([0.0, 0.6, 0.9]))}
        reference = Reference({"references": [{"probe": "x", "expression": "t"}]})
        self.assertAlmostEqual(probe_error(history, reference, "x", {}), 0.1, places=14)
        self.assertAlmostEqual(probe_error(history, reference, "x", {"error": "END"}), 0.1, places=14)
        self.assertAlmostEqual(probe_error(history, reference, "x", {"error_from": 0.9}), 0.1, places=14)
        self.assertTrue(math.isnan(probe_error(history, reference, "y", {})))

    def test_a_reference_run_is_interpolated_between_its_rows(self):
        reference = Reference({}, {"x": (np.array([0.0, 1.0]), np.array([0.0, 2.0]))})
        np.testing.assert_allclose(reference.values("x", [0.0, 0.25, 1.0]), [0.0, 0.5, 2.0])

    def test_halvings_and_output_decimation(self):
        # At least four halvings from the coarsest step; every run writes the coarsest run's times.
        steps = halving_steps({"numerics": {"step": 0.01}}, {"halvings": 2})
        self.assertEqual(steps, [0.01, 0.005, 0.0025, 0.00125, 0.000625])
        self.assertEqual(every_for({"output": {"every": 2}}, 0.0025, 0.01), 8)
        self.assertEqual(every_for({}, 0.01, 0.01), 1)

    def test_contact_episodes(self):
        # Runs of |value| above the floor, with their first and last samples in contact.
        times = [0.0, 0.1, 0.2, 0.3, 0.4, 0.5]
        self.assertEqual(contact_episodes(times, [0, 5, 6, 0, 0, -2]), [(0.1, 0.2, 1, 2), (0.5, 0.5, 5, 5)])
        self.assertEqual(contact_episodes(times, [1, 1, 0, 0, 0, 0], floor=1.0), [])

    def test_fmt(self):
        self.assertEqual(fmt(0.000123456), "0.000123")

    def test_same_overrides_accepts_a_shipped_file_only_if_unchanged(self):
        # A file sent to a worker is recorded at the worker's copy: the same name, and not
        # rewritten since the run (a new settling run's state makes the runs from it run again).
        with tempfile.TemporaryDirectory() as d:
            state, summary = os.path.join(d, "final_state.pb"), os.path.join(d, "summary.json")
            open(state, "w").close()
            time.sleep(0.01)
            open(summary, "w").close()
            wanted = [f"numerics.initial_state={state}", "numerics.step=0.001"]
            recorded = ["numerics.initial_state=/worker/copy/final_state.pb", "numerics.step=0.001"]
            self.assertTrue(same_overrides(recorded, wanted, summary))
            self.assertFalse(same_overrides(recorded[:1], wanted, summary))
            self.assertFalse(same_overrides(["numerics.initial_state=/w/other.pb", recorded[1]], wanted, summary))
            os.utime(state, (time.time() + 10, time.time() + 10))
            self.assertFalse(same_overrides(recorded, wanted, summary))


class Studies(unittest.TestCase):
    def test_relaxation_sets(self):
        self.assertEqual(
            relaxation_sets("CONSTANT(0.05)"),
            ["coupling.iteration.relaxation=CONSTANT", "coupling.iteration.relaxation_factor=0.05"],
        )
        self.assertEqual(
            relaxation_sets("IQN_ILS(4)"),
            ["coupling.iteration.relaxation=IQN_ILS", "coupling.iteration.reuse_steps=4"],
        )
        self.assertEqual(relaxation_sets("AITKEN"), ["coupling.iteration.relaxation=AITKEN"])
        with self.assertRaises(StudyError):
            relaxation_sets("NEWTON")

    def test_axis_sets_evaluate_each_braced_expression_of_v(self):
        axis = {"set": ["model.air.wind_x.constant={v*cos(radians(30))}", "numerics.step=0.001"]}
        sets = axis_sets(axis, 2.0, "study.envelope.axes[0]")
        self.assertEqual(sets[1], "numerics.step=0.001")
        self.assertAlmostEqual(float(sets[0].split("=")[1]), 2.0 * math.cos(math.radians(30)), places=15)
        with self.assertRaises(StudyError):
            axis_sets({"set": ["no equals sign"]}, 1.0, "a")
        with self.assertRaises(StudyError):
            axis_sets({"set": ["x={1/(v-1)}"]}, 1.0, "a")

    def test_unsafe_points_count_failed_runs_as_unsafe(self):
        runs = [
            Run(id=f"p{i}", scenario="s.pbtxt", sets=[], out="", code=code, measured={"clearance": c})
            for i, (code, c) in enumerate([(0, 0.5), (0, 0.1), (3, float("nan")), (0, float("nan"))])
        ]
        self.assertEqual(unsafe_points(runs, 0.3), [False, True, True, None])

    def test_a_run_records_its_outcome_from_its_summary(self):
        # The time in the steps (step_wall_time) is the method's cost, not the process's seconds;
        # what failed is the run's own reason, else the last line the process wrote.
        with tempfile.TemporaryDirectory() as d:
            with open(os.path.join(d, "summary.json"), "w") as f:
                f.write('{"exit_code": 3, "reason": "Newton diverged", "step_wall_time": 1.5, "wall_time": 2.0}')
            run = Run(id="h=0.1", scenario="s.pbtxt", sets=["numerics.step=0.1"], out=d, labels={"h": 0.1})
            self.assertIsNone(run.code)  # not run yet
            record(run, 3, 2.4, "worker-1", "warning\nlast words")
            self.assertEqual((run.code, run.wall, run.seconds, run.host), (3, 1.5, 2.4, "worker-1"))
            self.assertEqual(run.message, "Newton diverged")
            self.assertFalse(run.ok)
            self.assertEqual(
                failures_section([run]).splitlines()[-1], "- h=0.1: exit 3 (numerical failure): Newton diverged"
            )
        lost = Run(id="lost", scenario="s.pbtxt", sets=[], out=os.path.join(ROOT, "no", "such", "folder"))
        record(lost, 4, 0.5, "?", "the Dask task failed: KilledWorker")
        self.assertEqual((lost.wall, lost.message, lost.summary), (0.5, "the Dask task failed: KilledWorker", None))
        self.assertEqual(failures_section([Run(id="r", scenario="", sets=[], out="")]), "Every run completed.")

    def test_the_results_table_takes_the_envelope_figures_from_its_runs(self):
        # Counted from runs.csv (a failed run has no clearance to compare), not written by hand.
        with tempfile.TemporaryDirectory() as d:
            path = os.path.join(d, "runs.csv")
            with open(path, "w") as f:
                f.write("wind speed,relative wind direction,exit,clearance\n")
                f.write("5,0,0,0.49\n45,120,0,-0.15\n45,60,3,nan\n40,90,0,0.02\n")
            self.assertEqual(
                envelope_headline(path, "kt"), "4 runs, 1 failed; the least clearance -0.15 m at 45 kt from 120°"
            )
            # Symmetric directions within round-off are all named, whichever finished first (the
            # gust envelope's 0° and 180° differ by 2.4e-11 m, and the lower one changed between
            # two regenerations with the runs' order).
            with open(path, "w") as f:
                f.write("gust peak,gust direction,exit,clearance\n")
                f.write("35,180,0,-0.4837558782431115\n25,0,0,0.1\n35,0,0,-0.483755878218993\n35,90,0,-0.4837558782\n")
            self.assertEqual(
                envelope_headline(path, "m/s"),
                "4 runs, 0 failed; the least clearance -0.48 m at 35 m/s from 0°, 90° and 180°",
            )

    def test_the_hand_written_rows_of_the_results_table_are_table_rows(self):
        # The shipped reading's rows are the table's (four cells each); a stray line is refused.
        rows = headline_rows(os.path.join(ROOT, "docs", "readings", "headline.md"))
        self.assertGreaterEqual(len(rows), 10)
        with open(os.path.join(ROOT, "docs", "results.md")) as f:
            results = f.read()
        for row in rows:
            self.assertIn(row + "\n", results)  # results.md has them as the reading says
        with tempfile.TemporaryDirectory() as d:
            path = os.path.join(d, "headline.md")
            with open(path, "w") as f:
                f.write("| a | b | c | d |\nnot a row\n")
            with self.assertRaises(StudyError):
                headline_rows(path)

    def test_compare_measures(self):
        # Means and extremes over a window; the first or last time a probe is back near its start.
        t = np.array([0.0, 1.0, 2.0, 3.0])
        history = {"p": (t, np.array([1.0, 3.0, 1.05, 5.0]))}
        self.assertAlmostEqual(compare_measure(history, {"probe": "p", "kind": "MEAN", "to": 2.0}), 5.05 / 3)
        self.assertEqual(compare_measure(history, {"probe": "p", "kind": "MAX"}), 5.0)
        self.assertEqual(compare_measure(history, {"probe": "p", "kind": "MIN", "from": 1.5}), 1.05)
        near = {"probe": "p", "kind": "LAST_NEAR_START", "tolerance": 0.1}
        self.assertEqual(compare_measure(history, near), 2.0)
        self.assertTrue(math.isnan(compare_measure(history, {"probe": "q", "kind": "MAX"})))


class ResultsPage(unittest.TestCase):
    def test_an_entry_with_settings_is_named_in_its_heading_and_its_settings_follow(self):
        # Three convergence entries of one scene had the same name and their override lists in
        # their headings (issue 52, item 3): each is now named, its settings on a line of their own.
        text = entry_heading("# Convergence: sharcs_hub\n\nbody\n", "sharcs_hub_damped", ["a=1", "b.c=2"])
        first, rest = text.split("\n", 1)
        self.assertEqual(first, "# Convergence: sharcs_hub_damped")
        self.assertIn("Settings beside the scene's own: `a=1`, `b.c=2`.", rest)
        self.assertTrue(rest.rstrip().endswith("body"))

    def test_the_contents_link_each_section_as_github_anchors_it(self):
        block = contents(["## Work against precision: four_bar\n", "## The shipped scenarios, as they run\n"])
        self.assertIn("- [Work against precision: four_bar](#work-against-precision-four_bar)", block)
        self.assertIn("- [The shipped scenarios, as they run](#the-shipped-scenarios-as-they-run)", block)

    def test_the_page_has_its_contents_and_no_settings_in_a_heading(self):
        with open(os.path.join(ROOT, "docs", "results.md")) as f:
            page = f.read()
        headings = [line[3:] for line in page.splitlines() if line.startswith("## ")]
        for title in headings:
            self.assertNotIn("=", title, title)  # no override list in a heading
        self.assertEqual(len(headings), len(set(headings)), "two sections with one heading")
        block = page.split("Contents:", 1)[1].split("\n## ", 1)[0]
        for title in headings:
            self.assertIn(f"[{title}](#", block, title)


class ContactUnits(unittest.TestCase):
    def test_each_contact_probe_is_labelled_with_its_quantitys_unit(self):
        # The compare tables' contact column held a pad's impulse per step (N s), a point contact's
        # force (N) and a joint stop's moment (N m, the Puma twin's CONTACT_FORCE) unmarked. The
        # unit comes from the probe's quantity, and from its element for CONTACT_FORCE.
        from studies.compare import probe_units, signed_peak

        class Runner:
            def scenario_json(self, scenario, sets=()):
                return {
                    "model": {
                        "forces": [
                            {"name": "stops", "joint_stop": {"joint": "flap"}},
                            {"name": "pad", "continuous_contact": {"body": "b"}},
                        ]
                    },
                    "output": {
                        "probes": [
                            {"name": "moment", "quantity": "CONTACT_FORCE", "entity": "stops"},
                            {"name": "force", "quantity": "CONTACT_FORCE", "entity": "pad"},
                            {"name": "impulse", "quantity": "IMPULSE", "entity": "pad1/droop1"},
                            {
                                "name": "flap",
                                "quantity": "JOINT_COORDINATE",
                                "entity": "flap",
                                "scale": 57.29577951308232,
                            },
                        ]
                    },
                }

        run = Run(id="r", scenario="s.pbtxt", sets=[], out="")
        units = probe_units(Runner(), run)
        self.assertEqual(units["moment"], "N m")
        self.assertEqual(units["force"], "N")
        self.assertEqual(units["impulse"], "N s (per step)")
        self.assertEqual(units["flap"], "rad or m × 57.2958")
        self.assertEqual(signed_peak([0.5, -3.0, 2.0]), -3.0)  # a trough stays one


class Help(unittest.TestCase):
    def test_the_help_describes_every_kind_and_option_for_a_user(self):
        # `study --help` printed a sentence meant for developers, listed `modes` without a
        # description and `--bin` without one (issue 50). Every kind the parser accepts is
        # described in the KIND table, every option has a help text.
        import subprocess

        script = os.path.join(os.path.dirname(__file__), "..", "..", "scripts", "study.py")
        p = subprocess.run(["/usr/bin/python3", script, "--help"], capture_output=True, text=True)
        self.assertEqual(p.returncode, 0, p.stderr)
        text = p.stdout
        self.assertNotIn("This module", text)
        self.assertNotIn("StudyError", text)
        table = text.split("KIND\n", 1)[1].split("\n\n", 1)[0]
        kinds = text.split("{", 1)[1].split("}", 1)[0].split(",")
        for kind in kinds:
            self.assertRegex(table, rf"(?m)^  {kind} +\S", kind)
        lines = text.split("options:", 1)[1].splitlines()
        for option in ("--out", "--jobs", "--scheduler", "--set", "--reuse", "--bin"):
            at = next(i for i, line in enumerate(lines) if line.strip().startswith(option))
            words = lines[at].split()[1:]
            if words and words[0].isupper():
                words = words[1:]  # the metavar
            continued = at + 1 < len(lines) and lines[at + 1].startswith(" " * 10)
            self.assertTrue(words or continued, f"{option} has no description")


if __name__ == "__main__":
    unittest.main()
