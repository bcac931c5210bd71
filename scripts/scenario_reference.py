#!/usr/bin/python3
"""Writes docs/scenario-reference.md, the scenario reference page, from the schema's comments.

The schema is proto/scenario.proto and every file it imports, transitively (google/protobuf/*
excepted): protoc compiles them into a FileDescriptorSet with their source info, from which
each message, field, oneof, enum and enum value takes its leading, trailing and detached
comments. Messages and enums are listed in the order they are reached from `Scenario`, depth
first through the field types (then nested types not used by a field), so the page does not
depend on which file holds which message; each section names its file.

    scripts/scenario_reference.py                  writes docs/scenario-reference.md
    scripts/scenario_reference.py --check          exits 1 if the committed page is not what
                                                   the schema generates, naming the first line
    scripts/scenario_reference.py --output FILE    writes (or checks) FILE instead
"""

import argparse
import os
import re
import subprocess
import sys
import tempfile

from google.protobuf import descriptor_pb2

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
TOP_FILE = "scenario.proto"  # relative to proto/, as protoc names it
ROOT_MESSAGE = "Scenario"
DEFAULT_OUTPUT = os.path.join("docs", "scenario-reference.md")
REGENERATE = "scripts/scenario_reference.py"

# Source-info path components (descriptor.proto's field numbers).
FILE_MESSAGE, FILE_ENUM, FILE_SYNTAX, FILE_PACKAGE = 4, 5, 12, 2
MESSAGE_FIELD, MESSAGE_NESTED, MESSAGE_ENUM, MESSAGE_ONEOF = 2, 3, 4, 8
ENUM_VALUE = 2

FDP = descriptor_pb2.FieldDescriptorProto
SCALAR_NAMES = {
    FDP.TYPE_DOUBLE: "double",
    FDP.TYPE_FLOAT: "float",
    FDP.TYPE_INT64: "int64",
    FDP.TYPE_UINT64: "uint64",
    FDP.TYPE_INT32: "int32",
    FDP.TYPE_FIXED64: "fixed64",
    FDP.TYPE_FIXED32: "fixed32",
    FDP.TYPE_BOOL: "bool",
    FDP.TYPE_STRING: "string",
    FDP.TYPE_BYTES: "bytes",
    FDP.TYPE_UINT32: "uint32",
    FDP.TYPE_SFIXED32: "sfixed32",
    FDP.TYPE_SFIXED64: "sfixed64",
    FDP.TYPE_SINT32: "sint32",
    FDP.TYPE_SINT64: "sint64",
}


class SchemaError(Exception):
    pass


# ---------------------------------------------------------------------------------------
# Reading the schema
# ---------------------------------------------------------------------------------------


def compile_schema(root=ROOT, top_file=TOP_FILE):
    """The FileDescriptorSet of proto/TOP_FILE and its imports, with source info."""
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "scenario.desc")
        command = [
            "protoc",
            "--include_source_info",
            "--include_imports",
            f"--descriptor_set_out={out}",
            "-I",
            "proto",
            os.path.join("proto", top_file),
        ]
        try:
            result = subprocess.run(command, cwd=root, capture_output=True, text=True)
        except OSError as e:
            raise SchemaError(f"cannot run protoc ({e}); it is Debian's protobuf-compiler")
        if result.returncode != 0:
            raise SchemaError(f"protoc failed on proto/{top_file}:\n{result.stderr.strip()}")
        with open(out, "rb") as f:
            data = f.read()
    files = descriptor_pb2.FileDescriptorSet()
    files.ParseFromString(data)
    return files


def import_closure(file_set, top_file=TOP_FILE):
    """The files reached from top_file through its imports (depth first, in import order),
    google/protobuf/* excluded."""
    by_name = {f.name: f for f in file_set.file}
    order = []

    def visit(name):
        if name in order or name.startswith("google/protobuf/"):
            return
        if name not in by_name:
            raise SchemaError(f"{name} is imported but not in protoc's descriptor set")
        order.append(name)
        for dependency in by_name[name].dependency:
            visit(dependency)

    visit(top_file)
    return [by_name[name] for name in order]


class Comments:
    """The comments of one element: detached (blocks before it, apart), leading, trailing."""

    def __init__(self, location=None):
        self.detached = list(location.leading_detached_comments) if location else []
        self.leading = location.leading_comments if location and location.HasField("leading_comments") else ""
        self.trailing = location.trailing_comments if location and location.HasField("trailing_comments") else ""

    def text(self, detached=True):
        """Every comment of the element, in the order written."""
        parts = (self.detached if detached else []) + [self.leading, self.trailing]
        parts = ["\n".join(line for line in p.split("\n") if not is_rule(line)) for p in parts]
        return "\n\n".join(p.strip("\n") for p in parts if p.strip())

    def empty(self):
        return not self.text()


def is_rule(line):
    """A comment line that is only a ruler (------)."""
    return re.fullmatch(r"\s*[-=*/]{10,}\s*", line) is not None


class Type:
    """A message or enum of the schema: its descriptor, file, qualified name and comments."""

    def __init__(self, kind, proto, file, package, qualified, path, locations):
        self.kind = kind  # "message" or "enum"
        self.proto = proto
        self.file = file
        self.package = package
        self.qualified = qualified  # Outer.Inner, without the package
        self.full = f".{package}.{qualified}" if package else f".{qualified}"
        self.path = path
        self.comments = Comments(locations.get(path))
        if kind == "message":
            self.field_comments = [Comments(locations.get(path + (MESSAGE_FIELD, i))) for i in range(len(proto.field))]
            self.oneof_comments = [
                Comments(locations.get(path + (MESSAGE_ONEOF, i))) for i in range(len(proto.oneof_decl))
            ]
        else:
            self.value_comments = [Comments(locations.get(path + (ENUM_VALUE, i))) for i in range(len(proto.value))]


class Schema:
    """Every message and enum of the import closure of proto/TOP_FILE, by full name."""

    def __init__(self, file_set, top_file=TOP_FILE):
        self.files = import_closure(file_set, top_file)
        self.types = {}  # full name -> Type, in file and declaration order
        self.file_comments = {}  # file name -> its header comment
        self.extensions = []  # FieldOptions extensions: (number, name, enum type full name or None)
        for f in self.files:
            locations = {tuple(loc.path): loc for loc in f.source_code_info.location}
            header = Comments(locations.get((FILE_SYNTAX,)))
            self.file_comments[f.name] = header.text()
            for i, message in enumerate(f.message_type):
                self._add_message(message, f.name, f.package, message.name, (FILE_MESSAGE, i), locations)
            for i, enum in enumerate(f.enum_type):
                self._add(Type("enum", enum, f.name, f.package, enum.name, (FILE_ENUM, i), locations))
            for extension in f.extension:
                if extension.extendee == ".google.protobuf.FieldOptions":
                    enum_type = extension.type_name if extension.type == FDP.TYPE_ENUM else None
                    self.extensions.append((extension.number, extension.name, enum_type))

    def _add(self, t):
        if t.full in self.types:
            raise SchemaError(f"{t.full} is declared twice ({self.types[t.full].file}, {t.file})")
        self.types[t.full] = t

    def _add_message(self, message, file, package, qualified, path, locations):
        self._add(Type("message", message, file, package, qualified, path, locations))
        for j, nested in enumerate(message.nested_type):
            if nested.options.map_entry:
                continue
            self._add_message(
                nested, file, package, f"{qualified}.{nested.name}", path + (MESSAGE_NESTED, j), locations
            )
        for j, enum in enumerate(message.enum_type):
            self._add(
                Type("enum", enum, file, package, f"{qualified}.{enum.name}", path + (MESSAGE_ENUM, j), locations)
            )

    def root(self, name=ROOT_MESSAGE):
        for t in self.types.values():
            if t.kind == "message" and t.qualified == name and t.package == self.files[0].package:
                return t
        raise SchemaError(f"no message {name} in proto/{self.files[0].name} or its imports")

    def nested_of(self, t):
        """The types declared inside message t, in declaration order (messages, then enums)."""
        prefix = t.full + "."
        return [u for u in self.types.values() if u.full.startswith(prefix) and "." not in u.full[len(prefix) :]]

    def order(self):
        """The types reached from the root message, depth first through field types, each type's
        nested types not used by a field after its fields; then the types not reached, by name.
        Returns (reached, unreached, first_path) with first_path[full] the field path by which a
        message was first reached (e.g. `model.contact_nodes[i]`)."""
        reached, seen, first_path = [], set(), {}

        def visit(t, path):
            if t.full in seen:
                return
            seen.add(t.full)
            reached.append(t)
            first_path[t.full] = path
            if t.kind != "message":
                return
            for field in t.proto.field:
                if field.type in (FDP.TYPE_MESSAGE, FDP.TYPE_GROUP, FDP.TYPE_ENUM):
                    if field.type_name not in self.types:
                        continue  # a type outside the closure (google.protobuf.*)
                    step = field.name + ("[i]" if field.label == FDP.LABEL_REPEATED else "")
                    visit(self.types[field.type_name], f"{path}.{step}" if path else step)
            for nested in self.nested_of(t):
                visit(nested, None)

        visit(self.root(), "")
        unreached = sorted((t for t in self.types.values() if t.full not in seen), key=lambda t: t.qualified)
        return reached, unreached, first_path

    def used_by(self):
        """For each type, the (message, field) pairs whose field has that type."""
        uses = {}
        for t in self.types.values():
            if t.kind == "message":
                for field in t.proto.field:
                    uses.setdefault(field.type_name, []).append((t, field))
        return uses


# ---------------------------------------------------------------------------------------
# Field options: custom ones arrive as unknown fields of FieldOptions (the extension is not
# registered in this Python process); they are read from its wire format.
# ---------------------------------------------------------------------------------------


def read_varint(data, i):
    value, shift = 0, 0
    while True:
        byte = data[i]
        i += 1
        value |= (byte & 0x7F) << shift
        shift += 7
        if not byte & 0x80:
            return value, i


def option_varints(options):
    """{field number: last varint value} of a FieldOptions' wire format (known and unknown)."""
    data = options.SerializeToString()
    values, i = {}, 0
    while i < len(data):
        key, i = read_varint(data, i)
        number, wire = key >> 3, key & 7
        if wire == 0:
            values[number], i = read_varint(data, i)
        elif wire == 1:
            i += 8
        elif wire == 2:
            length, i = read_varint(data, i)
            i += length
        elif wire == 5:
            i += 4
        else:
            raise SchemaError(f"field option {number}: wire type {wire} not read")
    return values


def custom_options(schema, field):
    """[(option name, value)] of the schema's FieldOptions extensions set on field; an enum's
    value by name."""
    found = []
    values = option_varints(field.options)
    for number, name, enum_type in schema.extensions:
        if number not in values:
            continue
        value = values[number]
        if enum_type and enum_type in schema.types:
            names = {v.number: v.name for v in schema.types[enum_type].proto.value}
            value = names.get(value, value)
        found.append((name, str(value)))
    return found


# ---------------------------------------------------------------------------------------
# Writing the page
# ---------------------------------------------------------------------------------------


def anchor(heading):
    """GitHub's anchor of a Markdown heading: lower case, punctuation dropped, spaces '-'."""
    return re.sub(r"[^\w\- ]", "", heading.lower()).replace(" ", "-")


def inline(text, cell=True):
    """A comment folded onto one line for a table cell (cell) or a paragraph: lines joined, '|'
    escaped in a cell, and outside `code` '<' and '*' escaped (so that <beam> and t**2 show as
    written)."""
    folded = " ".join(line.strip() for line in text.split("\n") if line.strip())
    pieces = folded.split("`")
    for k in range(0, len(pieces), 2):  # the even pieces are outside code spans
        pieces[k] = pieces[k].replace("<", "&lt;").replace("*", "\\*")
    if len(pieces) % 2 == 0:  # an unmatched backtick: escape it
        pieces[-2] += "\\`" + pieces.pop()
    joined = "`".join(pieces)
    return joined.replace("|", "\\|") if cell else joined


def paragraphs(text):
    """A comment as Markdown paragraphs (its blank lines kept)."""
    return "\n\n".join(inline(block, cell=False) for block in re.split(r"\n\s*\n", text) if block.strip())


def default_text(field):
    if not field.HasField("default_value"):
        return ""
    value = field.default_value
    if field.type == FDP.TYPE_STRING:
        value = '"' + value + '"'
    return "`" + value.replace("|", "\\|") + "`"


def type_cell(schema, field, anchors):
    if field.type in SCALAR_NAMES:
        return SCALAR_NAMES[field.type]
    t = schema.types.get(field.type_name)
    if t is None:
        return "`" + field.type_name.lstrip(".") + "`"
    return f"[{t.qualified}](#{anchors[t.full]})"


def label_cell(message, field):
    if field.HasField("oneof_index"):
        return "oneof `" + message.proto.oneof_decl[field.oneof_index].name + "`"
    return {FDP.LABEL_OPTIONAL: "optional", FDP.LABEL_REPEATED: "repeated", FDP.LABEL_REQUIRED: "required"}[field.label]


def heading(t):
    return t.qualified


def message_section(schema, t, anchors, first_path, uses):
    lines = [f"### {heading(t)}", ""]
    facts = [f"message in `proto/{t.file}`"]
    if first_path.get(t.full):
        facts.append(f"path `{first_path[t.full]}`")
    elif t.qualified == ROOT_MESSAGE:
        facts.append("the scenario file's top level")
    lines += section_preamble(t, facts, anchors, uses)
    fields = t.proto.field
    if not fields:
        return lines + ["No fields.", ""]
    options = [custom_options(schema, f) for f in fields]
    option_names = sorted({name for found in options for name, _ in found})
    header = ["Field", "Type", "Label", "Default", "No."] + option_names + ["Description"]
    lines += ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for field, comments, found in zip(fields, t.field_comments, options):
        values = dict(found)
        row = [
            f"`{field.name}`",
            type_cell(schema, field, anchors),
            label_cell(t, field),
            default_text(field),
            str(field.number),
        ]
        row += [f"`{values[name]}`" if name in values else "" for name in option_names]
        row.append(inline(comments.text()))
        lines.append("| " + " | ".join(row) + " |")
    lines.append("")
    oneof_notes = []
    for index, (oneof, comments) in enumerate(zip(t.proto.oneof_decl, t.oneof_comments)):
        members = ", ".join(f"`{f.name}`" for f in fields if f.HasField("oneof_index") and f.oneof_index == index)
        note = f"- oneof `{oneof.name}` (at most one of {members})"
        if not comments.empty():
            note += ": " + inline(comments.text())
        oneof_notes.append(note)
    if oneof_notes:
        lines += oneof_notes + [""]
    return lines


def section_preamble(t, facts, anchors, uses):
    """A section's italic line of facts (with the fields that use the type) and its comment."""
    users = uses.get(t.full, [])
    if users:
        links = sorted({f"[{m.qualified}](#{anchors[m.full]}).`{f.name}`" for m, f in users})
        facts = facts + ["used by " + ", ".join(links)]
    lines = ["*" + "; ".join(facts) + "*", ""]
    if not t.comments.empty():
        lines += [paragraphs(t.comments.text()), ""]
    return lines


def enum_section(schema, t, anchors, uses):
    lines = [f"### {heading(t)}", ""]
    facts = [f"enum in `proto/{t.file}`"]
    lines += section_preamble(t, facts, anchors, uses)
    lines += ["| Value | Number | Description |", "|---|---|---|"]
    for value, comments in zip(t.proto.value, t.value_comments):
        lines.append(f"| `{value.name}` | {value.number} | {inline(comments.text())} |")
    return lines + [""]


def section_anchors(types):
    """The anchor of each type's section, by its full name; two alike are an error."""
    fixed_headings = ["Scenario reference", "How to read it", "Schema files", "Contents", "Not reached from Scenario"]
    anchors, taken = {}, {anchor(h) for h in fixed_headings}
    for t in types:
        a = anchor(heading(t))
        if a in taken:
            raise SchemaError(f"two sections would have the anchor #{a} ({t.qualified})")
        taken.add(a)
        anchors[t.full] = a
    return anchors


def schema_files(schema, top_file):
    """The list of the schema's files with their first sentences, then the top file's header."""
    out = []
    for f in schema.files:
        out.append(
            f"- `proto/{f.name}`"
            + (f": {inline(first_sentence(schema.file_comments[f.name]))}" if schema.file_comments[f.name] else "")
        )
    out.append("")
    header = schema.file_comments.get(top_file, "")
    if header:
        out += [f"From the header of `proto/{top_file}`:", ""]
        for k, block in enumerate(paragraphs(header).split("\n\n")):
            out += ([">"] if k else []) + ["> " + block]
        out.append("")
    return out


def generate(file_set, top_file=TOP_FILE):
    """The page's Markdown text for the schema in file_set."""
    schema = Schema(file_set, top_file)
    reached, unreached, first_path = schema.order()
    uses = schema.used_by()
    anchors = section_anchors(reached + unreached)

    messages = [t for t in reached + unreached if t.kind == "message"]
    field_count = sum(len(t.proto.field) for t in messages)
    uncommented = sum(1 for t in messages for c in t.field_comments if c.empty())
    option_names = ", ".join(f"`{name}`" for _, name, _ in schema.extensions) or "none"

    out = [
        "# Scenario reference",
        "",
        f"<!-- Generated by {REGENERATE} from proto/{top_file} and its imports; do not edit by hand:",
        f"     change the schema's comments and run {REGENERATE} (ctest checks the two agree). -->",
        "",
        "Every message and field of a scenario file, from the schema's own comments: "
        f"{len(messages)} messages, {sum(1 for t in reached + unreached if t.kind == 'enum')} enums, "
        f"{field_count} fields ({field_count - uncommented} with a comment).",
        "",
        "## How to read it",
        "",
        "- A scenario is a protobuf text file (`name: value`, `message { ... }`, repeated fields "
        "written once per element or as `[a, b, c]` lists) whose top message is "
        f"[{ROOT_MESSAGE}](#{anchors[schema.root().full]}). Sections follow the order in which the "
        "types are reached from it, depth first through the fields' types; each names the "
        "`.proto` file that declares it.",
        "- *path* under a message's heading is the field path by which it was first reached, as "
        "`--set PATH=VALUE` and error messages write it: dotted field names, `[i]` (0-based index) "
        "or `[name]` (the element whose `name` is `name`) on repeated fields, e.g. "
        "`model.contact_nodes[ball].mass` or `numerics.step`. A message used in several places "
        "lists them under *used by*.",
        "- **Default** is the schema's proto2 `[default = ...]`: the value a scenario that leaves "
        "the field out is read with. Many fields' defaults are instead described in their comment "
        "(a list's default, or one that depends on other fields), and a field without either may "
        "be required by the validator, which names the field path when it is missing.",
        "- Units are SI (m, kg, s, N, rad) and are written in brackets in the descriptions, as the "
        "schema's comments write them, e.g. `[m]`, `[rad/s]`; vectors are `[x, y, z]` in the "
        "global frame unless the description says otherwise.",
        "- **Label**: `optional`, `repeated`, or `oneof NAME` for a field of a oneof group (at most "
        "one of the group is set; listed under the table).",
        f"- Custom field options ({option_names}) have a column where a message sets them. "
        "`geometry` says how a copy of a [Pattern](#"
        + anchors.get(f".{schema.files[0].package}.Pattern", "pattern")
        + ") transforms the field: `POINT` about the pattern's axis, `DIRECTION` (and velocities, "
        "forces) by the rotation, `ROTATION_VECTOR` composed with it; fields without it are "
        "copied unchanged.",
        "- Descriptions are the fields' leading and trailing comments, with any comment block "
        "written apart just above a field (a heading of a group of fields) before them.",
        "",
        "## Schema files",
        "",
    ]
    out += schema_files(schema, top_file)
    out += ["## Contents", ""]
    for t in reached:
        depth = t.qualified.count(".")
        out.append("  " * depth + f"- [{t.qualified}](#{anchors[t.full]})" + (" (enum)" if t.kind == "enum" else ""))
    if unreached:
        out.append(f"- [Not reached from Scenario](#{anchor('Not reached from Scenario')})")
    out.append("")
    for t in reached:
        if t.kind == "message":
            out += message_section(schema, t, anchors, first_path, uses)
        else:
            out += enum_section(schema, t, anchors, uses)
    if unreached:
        out += [
            "## Not reached from Scenario",
            "",
            "Types declared in the schema's files that no field reached from Scenario uses (a "
            "field option's type, for one).",
            "",
        ]
        for t in unreached:
            if t.kind == "message":
                out += message_section(schema, t, anchors, first_path, uses)
            else:
                out += enum_section(schema, t, anchors, uses)
    return "\n".join(out).rstrip("\n") + "\n"


def first_sentence(text):
    folded = " ".join(text.split())
    match = re.match(r"(.+?\.)(\s|$)", folded)
    return match.group(1) if match else folded


# ---------------------------------------------------------------------------------------
# Command line
# ---------------------------------------------------------------------------------------


def check(expected, path, shown):
    """0 when the file at path is expected; else 1, naming the first line that differs."""
    try:
        with open(path, encoding="utf-8") as f:
            actual = f.read()
    except OSError as e:
        print(f"{shown}: cannot read it ({e.strerror}); run {REGENERATE} to write it")
        return 1
    if actual == expected:
        return 0
    want, have = expected.split("\n"), actual.split("\n")
    for n in range(max(len(want), len(have))):
        w = want[n] if n < len(want) else "<end of file>"
        h = have[n] if n < len(have) else "<end of file>"
        if w != h:
            print(
                f"{shown}:{n + 1}: not what the schema (proto/{TOP_FILE} and its imports) generates\n"
                f"  committed: {h}\n  generated: {w}\n"
                f"Run {REGENERATE} to regenerate it, and commit it with the schema."
            )
            return 1
    return 0


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", action="store_true", help="compare the page with the schema instead of writing it")
    parser.add_argument("--output", help=f"the page (default: {DEFAULT_OUTPUT} in the source tree)")
    args = parser.parse_args(argv)
    path = args.output if args.output else os.path.join(ROOT, DEFAULT_OUTPUT)
    shown = args.output if args.output else DEFAULT_OUTPUT
    try:
        text = generate(compile_schema())
    except SchemaError as e:
        print(f"scenario_reference: {e}", file=sys.stderr)
        return 2
    if args.check:
        return check(text, path, shown)
    with open(path, "w", encoding="utf-8") as f:
        f.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
