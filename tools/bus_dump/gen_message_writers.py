#!/usr/bin/env python3
"""Generates fieldline-bus-dump's JSON and CSV writers from lcmtypes/*.lcm, at build time, so a
field added to a message type is printed without anyone remembering to (docs/tools.md).

usage: gen_message_writers.py OUT.hpp TYPE.lcm...

For every struct, as inline functions: write(std::string&, const T&, const JsonOptions&) (a JSON object, fields in
the .lcm's order, nested structs as objects, arrays as arrays, booleans as true/false, byte
arrays as NAME_fnv1a64 unless JsonOptions::image_data), csvHeader(std::string&, const T*) and
csvRow(std::string&, const T&, const JsonOptions&) (one column per scalar, per element of a
fixed-size array, and per field of a nested struct as `header.utime`; a variable-length array in
one cell as a JSON array). Refuses (exit 1) a .lcm it cannot read, naming file and line.
"""
import pathlib
import re
import sys

PRIMITIVES = {"int8_t", "int16_t", "int32_t", "int64_t", "float", "double", "string", "boolean",
              "byte"}
MEMBER = re.compile(r"^\s*([A-Za-z_][\w.]*)\s+([A-Za-z_]\w*)\s*((?:\[[^\]]*\]\s*)*);\s*$")
CONST = re.compile(r"^\s*const\b")
STRUCT = re.compile(r"^\s*struct\s+(\w+)")
PACKAGE = re.compile(r"^\s*package\s+(\w+)\s*;")


def fail(message):
    print(f"gen_message_writers: {message}", file=sys.stderr)
    sys.exit(1)


def parse(path):
    """Returns (package, struct name, [(type, name, [dims])]) of one .lcm file."""
    package, name, members = None, None, []
    in_block = False
    for number, raw in enumerate(path.read_text().splitlines(), 1):
        line = raw.split("//", 1)[0]
        if in_block:
            if "*/" in line:
                in_block = False
            continue
        if "/*" in line:
            in_block = "*/" not in line
            continue
        if not line.strip() or line.strip() in ("{", "}"):
            continue
        if m := PACKAGE.match(line):
            package = m.group(1)
            continue
        if m := STRUCT.match(line):
            name = m.group(1)
            continue
        if CONST.match(line):
            continue
        m = MEMBER.match(line)
        if not m or name is None:
            fail(f"{path}:{number}: cannot read '{raw.strip()}'")
        dims = re.findall(r"\[\s*([^\]\s]+)\s*\]", m.group(3))
        if len(dims) > 1:
            fail(f"{path}:{number}: arrays of more than one dimension are not supported")
        members.append((m.group(1).split(".")[-1], m.group(2), dims))
    if package is None or name is None:
        fail(f"{path}: no package or struct")
    return package, name, members


def json_writer(package, name, members):
    out = [f"inline void write(std::string& out, const {package}::{name}& m, const JsonOptions& options) {{",
           "  (void)options;", "  json::Object o(out);"]
    for type_, field, dims in members:
        value = f"m.{field}"
        if type_ not in PRIMITIVES:
            out.append(f'  write(o.key("{field}"), {value}, options);')
        elif not dims:
            if type_ == "boolean":
                out.append(f'  o.boolean("{field}", {value} != 0);')
            else:
                out.append(f'  appendValue(o.key("{field}"), {value});')
        elif type_ == "byte":
            out.append("  if (options.image_data) {")
            out.append(f'    appendArray(o.key("{field}"), {value});')
            out.append("  } else {")
            out.append(f'    appendHash(o.key("{field}_fnv1a64"), {value});')
            out.append("  }")
        elif type_ == "boolean":
            out.append(f'  appendBoolArray(o.key("{field}"), {value});')
        else:
            out.append(f'  appendArray(o.key("{field}"), {value});')
    out.append("}")
    return "\n".join(out)


def csv_columns(structs, package, name, prefix=""):
    """Column names of a struct, flattened."""
    cols = []
    for type_, field, dims in structs[name]:
        if type_ not in PRIMITIVES:
            cols += csv_columns(structs, package, type_, f"{prefix}{field}.")
        elif dims and dims[0].isdigit():
            if type_ == "byte":
                cols.append(f"{prefix}{field}_fnv1a64")
            else:
                cols += [f"{prefix}{field}[{i}]" for i in range(int(dims[0]))]
        elif dims and type_ == "byte":
            cols.append(f"{prefix}{field}_fnv1a64")
        else:
            cols.append(f"{prefix}{field}")
    return cols


def csv_writer(structs, package, name):
    header = ",".join(csv_columns(structs, package, name))
    out = [f"inline void csvHeader(std::string& out, const {package}::{name}*) {{",
           f'  out += "{header}";', "}",
           f"inline void csvRow(std::string& out, const {package}::{name}& m, const JsonOptions& options) {{",
           "  (void)options;", "  bool first = true;",
           "  const auto next = [&]() -> std::string& { if (!first) out += ','; first = false; return out; };"]

    def cells(struct_name, access):
        lines = []
        for type_, field, dims in structs[struct_name]:
            value = f"{access}.{field}"
            if type_ not in PRIMITIVES:
                lines += cells(type_, value)
            elif not dims:
                if type_ == "boolean":
                    lines.append(f'  next() += {value} ? "1" : "0";')
                elif type_ == "string":
                    lines.append(f"  appendCsvString(next(), {value});")
                else:
                    lines.append(f"  appendValue(next(), {value});")
            elif type_ == "byte":
                lines.append(f"  appendHash(next(), {value});")
            elif dims[0].isdigit():
                for i in range(int(dims[0])):
                    if type_ == "boolean":
                        lines.append(f'  next() += {value}[{i}] ? "1" : "0";')
                    elif type_ == "string":
                        lines.append(f"  appendCsvString(next(), {value}[{i}]);")
                    else:
                        lines.append(f"  appendValue(next(), {value}[{i}]);")
            else:
                fn = "appendBoolArray" if type_ == "boolean" else "appendArray"
                lines.append("  {")
                lines.append("    std::string cell;")
                lines.append(f"    {fn}(cell, {value});")
                lines.append("    appendCsvString(next(), cell);")
                lines.append("  }")
        return lines

    out += cells(name, "m")
    out.append("}")
    return "\n".join(out)


def main():
    if len(sys.argv) < 3:
        fail("usage: gen_message_writers.py OUT.hpp TYPE.lcm...")
    parsed = [parse(pathlib.Path(p)) for p in sorted(sys.argv[2:])]
    structs = {name: members for _, name, members in parsed}
    for _, name, members in parsed:
        for type_, field, _ in members:
            if type_ not in PRIMITIVES and type_ not in structs:
                fail(f"{name}.{field}: unknown type {type_}")
    # Nested types first, so their writers are declared before use.
    order = sorted(parsed, key=lambda p: (any(t not in PRIMITIVES for t, _, _ in p[2]), p[1]))
    text = ["// Generated by tools/bus_dump/gen_message_writers.py from lcmtypes/*.lcm at build time:",
            "// do not edit. One JSON writer and one CSV header/row writer per message type.",
            "#pragma once", "",
            '#include "tools/bus_dump/message_writers.hpp"', "",
            "namespace fieldline::bus_dump::generated {", ""]
    for package, name, members in order:
        text.append(json_writer(package, name, members))
        text.append("")
        text.append(csv_writer(structs, package, name))
        text.append("")
    text.append("}  // namespace fieldline::bus_dump::generated")
    content = "\n".join(text) + "\n"
    out = pathlib.Path(sys.argv[1])
    if not out.exists() or out.read_text() != content:
        out.write_text(content)


if __name__ == "__main__":
    main()
