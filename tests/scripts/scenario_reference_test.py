#!/usr/bin/python3
"""Unit tests of the scenario reference page's generator (scripts/scenario_reference.py): the
page of the real schema shows defaults, units, the geometry option and every field once; on
small schemas written here, comments are taken from the right places, imports are followed and
the order does not depend on which file holds which message; a schema changed without
regenerating the page fails the check. Run by ctest (ScenarioReference.PageOfTheSchema) or
directly: tests/scripts/scenario_reference_test.py [SOURCE_ROOT]."""
import contextlib
import io
import os
import re
import shutil
import sys
import tempfile
import unittest

ROOT = os.path.abspath(
    sys.argv.pop(1) if len(sys.argv) > 1 else os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
)
sys.path.insert(0, os.path.join(ROOT, "scripts"))
import scenario_reference as ref  # noqa: E402


def sections(page):
    """{heading: the lines under it up to the next heading} of the ### sections."""
    found, current = {}, None
    for line in page.split("\n"):
        if line.startswith("#"):
            current = line[4:] if line.startswith("### ") else None
            if current is not None:
                if current in found:
                    raise AssertionError(f"section {current} appears twice")
                found[current] = []
        elif current is not None:
            found[current].append(line)
    return found


def table(lines):
    """The rows of the first table in lines, as {column: cell} with '\\|' kept in the cells."""
    rows = [line for line in lines if line.startswith("|")]
    if not rows:
        return []

    def cells(line):
        return [c.strip() for c in re.split(r"(?<!\\)\|", line)[1:-1]]

    header = cells(rows[0])
    return [dict(zip(header, cells(line))) for line in rows[2:]]


def row(page_sections, message, field):
    matches = [r for r in table(page_sections[message]) if r["Field"] == f"`{field}`"]
    if len(matches) != 1:
        raise AssertionError(f"{message}.{field}: {len(matches)} rows")
    return matches[0]


def write_tree(root, files):
    for name, text in files.items():
        path = os.path.join(root, "proto", name)
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, "w", encoding="utf-8") as f:
            f.write(text)


def page_of(files):
    with tempfile.TemporaryDirectory() as tmp:
        write_tree(tmp, files)
        return ref.generate(ref.compile_schema(root=tmp))


class RealSchema(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.file_set = ref.compile_schema(root=ROOT)
        cls.schema = ref.Schema(cls.file_set)
        cls.page = ref.generate(cls.file_set)
        cls.sections = sections(cls.page)

    def test_a_known_field_shows_its_default_and_unit(self):
        start = row(self.sections, "Numerics", "start_time")
        self.assertEqual(start["Default"], "`0`")
        self.assertIn("[s]", start["Description"])
        relative = row(self.sections, "AdaptiveStep", "relative")
        self.assertEqual(float(relative["Default"].strip("`")), 1e-4)  # written 1e-4, protoc says 0.0001
        self.assertIn("dimensionless", relative["Description"])
        self.assertIn("[s]", row(self.sections, "AdaptiveStep", "min_step")["Description"])
        # An enum's default by name, and no default where the schema gives none.
        self.assertEqual(row(self.sections, "Study", "error")["Default"], "`MAX`")
        self.assertEqual(row(self.sections, "Numerics", "end_time")["Default"], "")

    def test_a_message_reached_only_via_a_nested_type_appears(self):
        axis = self.schema.types[".cosim.scenario.Study.Envelope.Axis"]
        users = self.schema.used_by()[axis.full]
        self.assertEqual({m.qualified for m, _ in users}, {"Study.Envelope"})  # only there
        self.assertIn("Study.Envelope.Axis", self.sections)
        self.assertIn("path `study.envelope.axes[i]`", "\n".join(self.sections["Study.Envelope.Axis"]))
        headings = list(self.sections)
        self.assertLess(headings.index("Study.Envelope"), headings.index("Study.Envelope.Axis"))
        self.assertIn("[Study.Envelope.Axis](#studyenvelopeaxis)", self.page)

    def test_every_field_of_every_message_appears_exactly_once(self):
        messages = [t for t in self.schema.types.values() if t.kind == "message"]
        self.assertGreater(len(messages), 60)
        total = 0
        for t in messages:
            with self.subTest(message=t.qualified):
                self.assertIn(t.qualified, self.sections)
                rows = [r["Field"].strip("`") for r in table(self.sections[t.qualified])]
                self.assertEqual(rows, [f.name for f in t.proto.field])
                total += len(rows)
        field_tables = [lines for lines in self.sections.values() if any(x.startswith("| Field |") for x in lines)]
        field_rows = sum(len(table(lines)) for lines in field_tables)
        self.assertEqual(field_rows, total)
        self.assertGreater(total, 400)
        for t in self.schema.types.values():
            if t.kind == "enum":
                values = [r["Value"].strip("`") for r in table(self.sections[t.qualified])]
                self.assertEqual(values, [v.name for v in t.proto.value], t.qualified)

    def test_the_geometry_option_shows_where_set(self):
        self.assertEqual(row(self.sections, "ContactNode", "position")["geometry"], "`POINT`")
        self.assertEqual(row(self.sections, "ContactNode", "velocity")["geometry"], "`DIRECTION`")
        self.assertEqual(row(self.sections, "ContactNode", "mass")["geometry"], "")
        self.assertEqual(row(self.sections, "RigidBody", "rotation")["geometry"], "`ROTATION_VECTOR`")
        self.assertNotIn("geometry", table(self.sections["Numerics"])[0])  # no column where none is set

    def test_the_page_is_deterministic(self):
        self.assertEqual(self.page, ref.generate(ref.compile_schema(root=ROOT)))
        self.assertNotIn(ROOT, self.page)

    def test_the_check_fails_when_the_schema_changes_without_regenerating(self):
        with tempfile.TemporaryDirectory() as tmp:
            shutil.copytree(os.path.join(ROOT, "proto"), os.path.join(tmp, "proto"))
            path = os.path.join(tmp, "proto", "scenario.proto")
            with open(path, encoding="utf-8") as f:
                text = f.read()
            marker = "  optional Numerics numerics = 4;"
            self.assertIn(marker, text)
            with open(path, "w", encoding="utf-8") as f:
                f.write(text.replace(marker, marker + "  // how it is integrated"))
            changed = ref.generate(ref.compile_schema(root=tmp))
            page = os.path.join(tmp, "page.md")
            with open(page, "w", encoding="utf-8") as f:
                f.write(self.page)
            said = io.StringIO()
            with contextlib.redirect_stdout(said):
                self.assertEqual(ref.check(changed, page, "page.md"), 1)
                self.assertEqual(ref.check(self.page, page, "page.md"), 0)
            self.assertIn("how it is integrated", row(sections(changed), "Scenario", "numerics")["Description"])
            self.assertIn("page.md:6: not what the schema", said.getvalue())  # the count of commented fields
            self.assertIn("Run scripts/scenario_reference.py", said.getvalue())


# A small schema: comments in every place, a nested message reached only through its parent, a
# oneof, an enum default and the geometry option, written as one file or split into three.
OPTION_FILE = """syntax = "proto2";
package cosim.scenario;
import "google/protobuf/descriptor.proto";
// Geometry's comment.
enum Geometry {
  GEOMETRY_NONE = 0;
  POINT = 1;  // a point
}
extend google.protobuf.FieldOptions {
  optional Geometry geometry = 51234;
}
"""
TOP = """// The header.
syntax = "proto2";
package cosim.scenario;
"""
SCENARIO = """
// Scenario's comment.
message Scenario {
  optional Second second = 1;  // trailing of second
  // leading of first
  repeated First first = 2;
}
"""
FIRST = """
// ---------------------------
// detached before First
// ---------------------------

// First's comment.
message First {
  // Inner's comment.
  message Inner {
    optional double depth = 1 [default = 2.5];  // [m]
  }
  // Mode's comment.
  enum Mode {
    MODE_NONE = 0;
    // leading of FAST
    FAST = 1;  // trailing of FAST
  }
  message Unused {  // declared here, the type of no field
    optional int32 n = 1;
  }
  optional Inner inner = 1;
  optional Mode mode = 2 [default = FAST];
  // the choice's comment
  oneof choice {
    double a = 3;  // [s]
    string b = 4 [default = "x|y"];
  }

  // detached before point

  repeated double point = 5 [(geometry) = POINT];  // the point
}
"""
SECOND = """
message Second {
  optional First again = 1;
  optional double value = 2;
}
"""


def split_files():
    return {
        "scenario.proto": TOP + 'import "scenario/second.proto";\nimport "scenario/first.proto";\n' + SCENARIO,
        "scenario/options.proto": OPTION_FILE,  # imported by first.proto only
        "scenario/first.proto": 'syntax = "proto2";\npackage cosim.scenario;\nimport "scenario/options.proto";\n'
        + FIRST,
        "scenario/second.proto": 'syntax = "proto2";\npackage cosim.scenario;\nimport "scenario/first.proto";\n'
        + SECOND,
    }


class SmallSchema(unittest.TestCase):
    maxDiff = None

    def test_comments_come_from_their_places(self):
        page = sections(page_of(split_files()))
        scenario = "\n".join(page["Scenario"])
        self.assertIn("Scenario's comment.", scenario)
        self.assertIn("trailing of second", row(page, "Scenario", "second")["Description"])
        self.assertEqual(row(page, "Scenario", "first")["Description"], "leading of first")
        first = "\n".join(page["First"])
        self.assertIn("detached before First", first)
        self.assertIn("First's comment.", first)
        self.assertNotIn("-----", first)
        self.assertIn("Inner's comment.", "\n".join(page["First.Inner"]))
        self.assertIn("Mode's comment.", "\n".join(page["First.Mode"]))
        fast = [r for r in table(page["First.Mode"]) if r["Value"] == "`FAST`"][0]
        self.assertEqual(fast["Description"], "leading of FAST trailing of FAST")
        self.assertIn("oneof `choice` (at most one of `a`, `b`): the choice's comment", first)
        self.assertEqual(row(page, "First", "a")["Label"], "oneof `choice`")
        self.assertEqual(row(page, "First", "a")["Description"], "[s]")
        self.assertEqual(row(page, "First", "b")["Default"], '`"x\\|y"`')
        self.assertEqual(row(page, "First", "mode")["Default"], "`FAST`")
        self.assertEqual(row(page, "First.Inner", "depth")["Default"], "`2.5`")
        self.assertEqual(row(page, "First", "point")["Description"], "detached before point the point")
        self.assertEqual(row(page, "First", "point")["geometry"], "`POINT`")
        self.assertEqual(row(page, "First", "point")["Label"], "repeated")
        self.assertIn("a point", [r["Description"] for r in table(page["Geometry"])])

    def test_imports_are_followed_and_each_section_names_its_file(self):
        text = page_of(split_files())
        page = sections(text)
        self.assertIn("message in `proto/scenario.proto`", "\n".join(page["Scenario"]))
        self.assertIn("message in `proto/scenario/first.proto`", "\n".join(page["First"]))
        self.assertIn("message in `proto/scenario/first.proto`", "\n".join(page["First.Inner"]))
        self.assertIn("message in `proto/scenario/second.proto`", "\n".join(page["Second"]))
        self.assertIn("enum in `proto/scenario/options.proto`", "\n".join(page["Geometry"]))
        listed = re.findall(r"^- `proto/([^`]+)`", text, re.M)
        self.assertEqual(
            listed, ["scenario.proto", "scenario/second.proto", "scenario/first.proto", "scenario/options.proto"]
        )
        self.assertNotIn("google/protobuf", text)
        self.assertIn("> The header.", text)

    def test_the_order_is_the_walk_from_scenario_whatever_the_files(self):
        one_file = {
            "scenario.proto": TOP
            + 'import "google/protobuf/descriptor.proto";\n'
            + "\n".join([OPTION_FILE.split('import "google/protobuf/descriptor.proto";\n')[1], SECOND, FIRST, SCENARIO])
        }
        split_page = page_of(split_files())
        split = list(sections(split_page))
        self.assertLess(split_page.index("### First.Unused"), split_page.index("## Not reached from Scenario"))
        self.assertLess(split_page.index("## Not reached from Scenario"), split_page.index("### Geometry"))
        whole = list(sections(page_of(one_file)))
        # Depth first: Scenario, its first field's type Second, whose field reaches First, First's
        # nested types (those no field uses after the others), then what is not reached (the
        # option's enum).
        expected = ["Scenario", "Second", "First", "First.Inner", "First.Mode", "First.Unused", "Geometry"]
        self.assertEqual(split, expected)
        self.assertEqual(whole, expected)

    def test_a_missing_import_or_root_is_an_error(self):
        files = {"scenario.proto": 'syntax = "proto2";\npackage cosim.scenario;\nmessage Other {}\n'}
        with self.assertRaisesRegex(ref.SchemaError, "no message Scenario"):
            page_of(files)
        with tempfile.TemporaryDirectory() as tmp:
            write_tree(tmp, {"scenario.proto": 'syntax = "proto2";\nimport "absent.proto";\n'})
            with self.assertRaisesRegex(ref.SchemaError, "protoc failed"):
                ref.compile_schema(root=tmp)


if __name__ == "__main__":
    unittest.main()
