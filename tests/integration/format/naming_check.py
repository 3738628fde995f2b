#!/usr/bin/env python3
"""The member naming rule of .clang-tidy (snake_case, private members with a trailing underscore),
checked over the whole tree at a fraction of a full clang-tidy run.

usage: naming_check.py ROOT BUILD_DIR [--jobs N] [--all-sources]

A full `scripts/tidy --all` parses every translation unit (over 200, most of them pulling in
OpenCV, Eigen, Boost or gtest) and took about 9 minutes of CPU. Members are declared in only two
places, and this check visits each once:
  1. every header under common/ services/ teamcomm/ tools/ tests/ bench/, all included by ONE
     generated translation unit (the heavy third-party headers are parsed once, not 200 times);
  2. the source files that define a class, struct or union of their own (a member can only be
     declared in such a body), each as the build compiles it, reporting on the file itself only.
     By default only those whose type bodies hold a declared name that a cheap scan finds
     suspect (not snake_case, or a trailing underscore on a private member missing or on a public
     or protected one present) go to clang-tidy, which decides; --all-sources sends every one of
     them (the scan is a filter for speed: it errs towards sending, but exotic declarations such
     as bit-fields it does not read). The scan reads a type body without what declares no
     non-static member: member function bodies, static members (the rule covers non-static
     ones only), parentheses, nested types (scanned as bodies of their own) and template
     arguments. Each clang-tidy run of a source costs about 10 s of CPU (OpenCV, Eigen, gtest).
Only the naming check runs (-checks=-*,readability-identifier-naming, options from .clang-tidy).

Exit status: 0 clean, 1 findings or a translation unit that does not compile (printed),
2 bad usage, 77 clang-tidy not installed (ctest reports the test as skipped).
"""
import concurrent.futures
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
import tempfile

FOLDERS = ("common", "services", "teamcomm", "tools", "tests", "bench")
CHECKS = "-*,readability-identifier-naming"
# A class, struct or union with a body: `struct Result {`, `class A final : public B {`.
TYPE_HEAD = re.compile(r"^\s*(?:template\s*<[^>]*>\s*)?(struct|class|union)\b[^;(){}]*\{", re.M)
# A declared name: `name;`, `name = value;`, `name{value};`, `name[4];`, or one of `a, b;`.
DECLARED = re.compile(r"\b([A-Za-z_]\w*)\s*(?:\[[^\]]*\]\s*)*(?:=[^;{}]*|\{[^{};]*\})?\s*[;,]")
# Where a function body starts: `) {`, `) const {`, `) : a_(x), b_(y) {`.
FUNCTION_HEAD = re.compile(r"\)[^;{}]*\{")
# A static member's declaration (static data members and static functions).
STATIC_DECLARATION = re.compile(r"(?:^|(?<=[;{}:]))\s*static\b[^;]*;")
TYPE_HEAD_IN_BODY = re.compile(r"\b(?:struct|class|union)\b[^;(){}]*\{")
PARENTHESES = re.compile(r"\([^()]*\)")
# Innermost template arguments, `<` right after a name (not `operator<`), closed within the
# declaration; applied until none is left.
TEMPLATE_ARGUMENTS = re.compile(r"(?<!operator)(?<=[\w:])<[^<>;{}]*>")
# A comment, a string literal or a character literal (not a digit separator: 1'000).
LITERAL_OR_COMMENT = re.compile(
    r"//[^\n]*|/\*.*?\*/|\"(?:\\.|[^\"\\\n])*\"|(?<!\w)'(?:\\.|[^'\\\n])'", re.S)
NOT_NAMES = {"return", "default", "delete", "override", "final", "const", "break", "continue"}
FINDING = re.compile(r"^(/[^:\n]+):(\d+):(\d+): (warning|error): (.*)$", re.M)


def our_files(root, suffix):
    found = []
    for folder in FOLDERS:
        for base, dirs, files in os.walk(os.path.join(root, folder)):
            dirs.sort()
            found += [os.path.join(base, f) for f in sorted(files) if f.endswith(suffix)]
    return found


def type_bodies(text):
    """(keyword, body) of every class, struct and union in `text`, comments and strings removed."""
    # In one pass, so that `//` in a string ("memq://") starts no comment.
    text = LITERAL_OR_COMMENT.sub(lambda m: '""' if m.group(0)[0] in "\"'" else "", text)
    for match in TYPE_HEAD.finditer(text):
        depth, end = 1, match.end()
        while end < len(text) and depth:
            depth += {"{": 1, "}": -1}.get(text[end], 0)
            end += 1
        yield match.group(1), text[match.end():end - 1]


def strip_innermost(body, pattern, replacement):
    """`body` with every match of `pattern` (an innermost pair: parentheses, template arguments)
    replaced, from the inside out, by `replacement`."""
    while True:
        stripped = pattern.sub("\x00", body)
        if stripped == body:
            return stripped.replace("\x00", replacement)
        body = stripped


def strip_nested(body, head, opening, closing, replacement):
    """`body` with each match of `head` (ending in `opening`) up to its balanced `closing`
    replaced by `replacement`."""
    start = 0
    while True:
        match = head.search(body, start)
        if not match:
            return body
        depth, end = 1, match.end()
        while end < len(body) and depth:
            depth += {opening: 1, closing: -1}.get(body[end], 0)
            end += 1
        body = body[:match.start()] + replacement + body[end:]
        start = match.start() + len(replacement)


def suspect_member(text):
    """A declared name in a type body of `text` that may break the rule, or None."""
    for keyword, body in type_bodies(text):
        # Member function bodies are not declarations of members (a local type in one is a type
        # body of its own above): fold them away, at any depth.
        body = strip_nested(body, FUNCTION_HEAD, "{", "}", ");")
        # Static data members are not what the member rule covers (clang-tidy's Public-,
        # Protected- and PrivateMemberCase apply to non-static ones only), and no member is
        # declared inside parentheses.
        body = strip_innermost(STATIC_DECLARATION.sub(";", body), PARENTHESES, "()")
        # A nested type's body is a type body of its own (scanned with its own access), and the
        # commas of template arguments (`std::pair<A, B>`, written without a space before `<` by
        # .clang-format, unlike a comparison) separate no declarators.
        body = strip_nested(body, TYPE_HEAD_IN_BODY, "{", "}", "{};")
        body = strip_innermost(body, TEMPLATE_ARGUMENTS, "<>")
        private = keyword == "class"
        for part in re.split(r"(?=\b(?:public|private|protected)\s*:)", body):
            if part.startswith("private"):
                private = True
            elif part.startswith(("public", "protected")):
                private = False
            for match in DECLARED.finditer(part):
                name = match.group(1)
                if name in NOT_NAMES:
                    continue
                snake = re.fullmatch(r"[a-z][a-z0-9_]*", name.rstrip("_"))
                if not snake or private != name.endswith("_"):
                    return name
    return None


def compile_flags(entries):
    """Include paths, defines and the language standard of all entries (for the header unit)."""
    flags = []
    for entry in entries:
        args = entry.get("arguments") or shlex.split(entry["command"])
        i = 0
        while i < len(args):
            arg = args[i]
            if arg in ("-I", "-isystem", "-D") and i + 1 < len(args):
                pair = [arg, args[i + 1]]
                if not any(flags[j:j + 2] == pair for j in range(0, len(flags) - 1)):
                    flags += pair
                i += 2
                continue
            if arg.startswith(("-I", "-D", "-std=")) and arg not in flags:
                flags.append(arg)
            i += 1
    return flags


def run_tidy(tidy, config, args):
    proc = subprocess.run([tidy, f"--config-file={config}", f"-checks={CHECKS}", "--quiet"] + args,
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    return proc.returncode, proc.stdout


def main(argv):
    if len(argv) < 3 or argv[1] in ("-h", "--help"):
        print(__doc__)
        return 2
    root, build = os.path.abspath(argv[1]), os.path.abspath(argv[2])
    jobs = int(argv[argv.index("--jobs") + 1]) if "--jobs" in argv else 2
    all_sources = "--all-sources" in argv
    tidy = shutil.which("clang-tidy")
    if tidy is None:
        print("naming_check: clang-tidy is not installed (scripts/setup): skipped")
        return 77
    config = os.path.join(root, ".clang-tidy")
    database = os.path.join(build, "compile_commands.json")
    for path in (config, database):
        if not os.path.isfile(path):
            print(f"naming_check: {path} is missing")
            return 2
    entries = json.load(open(database))
    compiled = {os.path.normpath(os.path.join(e["directory"], e["file"])): e for e in entries}

    headers = our_files(root, ".hpp")
    sources = []
    with_types = 0
    for path in our_files(root, ".cpp"):
        text = open(path, errors="replace").read()
        if path not in compiled or not TYPE_HEAD.search(text):
            continue
        with_types += 1
        if all_sources or suspect_member(text):
            sources.append(path)

    outputs = []
    with tempfile.TemporaryDirectory() as tmp, \
            concurrent.futures.ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
        unit = os.path.join(tmp, "all_headers.cpp")
        with open(unit, "w") as out:
            out.writelines(f'#include "{h}"\n' for h in headers)
        # Headers only here (their own rule lives in .clang-tidy's HeaderFilterRegex); sources
        # report on themselves only, their headers are covered by the header unit. The build's
        # -Werror is lifted: clang warns where gcc does not (e.g. unused private fields), and
        # such warnings are not this check's business.
        jobs_run = [pool.submit(run_tidy, tidy, config,
                                [unit, "--"] + compile_flags(entries) + ["-I" + root])]
        jobs_run += [pool.submit(run_tidy, tidy, config,
                                 ["-p", build, "--header-filter=^$", "--extra-arg=-Wno-error", s]) for s in sources]
        outputs = [j.result() for j in jobs_run]

    findings = set()
    broken = 0
    for rc, text in outputs:
        # Naming findings are warnings (exit 0); anything else is a unit that did not compile.
        if rc != 0:
            broken += 1
            print(text)
        for m in FINDING.finditer(text):
            path, line, col, kind, message = m.groups()
            if kind == "warning" and "readability-identifier-naming" not in message:
                continue
            findings.add((os.path.relpath(path, root), int(line), int(col), kind, message))
    for path, line, col, kind, message in sorted(findings):
        print(f"{path}:{line}:{col}: {kind}: {message}")
    print(f"naming_check: {len(findings)} findings in {len(headers)} headers (one unit) and "
          f"{len(sources)} of the {with_types} source files with types of their own")
    if broken:
        print(f"naming_check: {broken} translation units failed to compile (above)")
    return 1 if findings or broken else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
