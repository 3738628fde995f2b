#!/usr/bin/env python3
"""The house rules on sizes (issue 33): no source file outside tests/ over MAX_FILE_LINES lines,
and no C++ function body over MAX_FUNCTION_LINES lines unless a comment line directly above it
says why (`// long: <reason>`).

Functions are found by a brace-matching scan of each file with comments, string and character
literals and preprocessor lines blanked out: at namespace, class or file scope a `{` opens a
function body when the declaration before it has a parameter list and no `=` (so lambdas and
braced initialisers are not functions, and count towards the function they are written in);
namespaces, classes, structs, unions and enums are scanned inside. A function's length is the
line of its closing brace minus the line of its opening brace, plus one.

Prints every violation as path:line: text and exits 1 if there is one, 0 otherwise.
usage: check_sizes.py [REPO_ROOT] [--list]   (--list prints every function over the limit, with
or without a reason, and every file's length over the limit)
"""

import os
import re
import sys

MAX_FILE_LINES = 700
MAX_FUNCTION_LINES = 80
# Where our code lives (tests/ is exempt: a test file grows with the cases of its component).
SOURCE_DIRS = ("common", "services", "tools", "teamcomm", "bench", "scripts", "cmake", "lcmtypes")
SOURCE_SUFFIXES = (".cpp", ".hpp", ".h", ".cc", ".py", ".sh", ".cmake", ".lcm")
CPP_SUFFIXES = (".cpp", ".hpp", ".h", ".cc")
REASON = re.compile(r"^\s*//\s*long:\s*\S")

# Files and functions still over the limit while they are being split, each with the reason
# (none is the goal): path -> reason, "path:function" -> reason.
KNOWN_LONG_FILES = {
}
KNOWN_LONG_FUNCTIONS = {
}


def blank_code(text):
    """The text with comments, string/character literals and preprocessor lines replaced by
    spaces (newlines kept, so offsets and line numbers stay)."""
    out = list(text)
    i, n = 0, len(text)

    def blank(a, b):
        for k in range(a, b):
            if out[k] != "\n":
                out[k] = " "

    at_line_start = True
    while i < n:
        c = text[i]
        if at_line_start and c == "#":
            # A preprocessor line, with its continuations.
            j = i
            while j < n and not (text[j] == "\n" and text[j - 1] != "\\"):
                j += 1
            blank(i, j)
            i = j
            continue
        if c == "\n":
            at_line_start = True
            i += 1
            continue
        if not c.isspace():
            at_line_start = False
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            blank(i, j)
            i = j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            blank(i, j)
            i = j
        elif c == '"':
            m = re.match(r'R"([^()\\ ]{0,16})\(', text[i - 1 : i + 20]) if i > 0 else None
            if m and (i < 2 or not (text[i - 2].isalnum() or text[i - 2] == "_") or
                      text[i - 2] in "uU8L"):
                end = text.find(")" + m.group(1) + '"', i)
                j = n if end < 0 else end + len(m.group(1)) + 2
            else:
                j = i + 1
                while j < n and text[j] != '"':
                    j += 2 if text[j] == "\\" else 1
                j += 1
            blank(i, j)
            i = j
        elif c == "'":
            # A digit separator (1'000, 0xff'ff) is no character literal.
            if i > 0 and text[i - 1].isalnum() and i + 1 < n and text[i + 1].isalnum() and \
                    re.search(r"[0-9][0-9a-fA-F']*$", text[max(0, i - 32) : i]):
                i += 1
                continue
            j = i + 1
            while j < n and text[j] != "'":
                j += 2 if text[j] == "\\" else 1
            j += 1
            blank(i, j)
            i = j
        else:
            i += 1
    return "".join(out)


def matching(code, open_at):
    """The index of the brace that closes the one at open_at (len(code) if none)."""
    depth = 0
    for k in range(open_at, len(code)):
        if code[k] == "{":
            depth += 1
        elif code[k] == "}":
            depth -= 1
            if depth == 0:
                return k
    return len(code)


def strip_groups(head):
    """The head at depth 0: parenthesised groups and template argument lists removed."""
    head = re.sub(r"\btemplate\s*<", "template<", head)
    out, depth_paren, k = [], 0, 0
    while k < len(head):
        c = head[k]
        if head.startswith("template<", k):
            depth, k = 1, k + len("template<")
            while k < len(head) and depth:
                depth += {"<": 1, ">": -1}.get(head[k], 0)
                k += 1
            continue
        if c == "(":
            depth_paren += 1
        elif c == ")":
            depth_paren = max(0, depth_paren - 1)
        elif depth_paren == 0:
            out.append(c)
        k += 1
    return "".join(out)


CONTAINER = re.compile(r"\b(namespace|class|struct|union|enum|extern)\b")
ASSIGNMENT = re.compile(r"(?<![=!<>+\-*/%&|^])=(?!=)")


def classify(head):
    """'container', 'function' or 'other' for the declaration text before a `{`."""
    flat = strip_groups(head)
    if CONTAINER.search(flat):
        return "container"
    if "(" not in head:
        return "other"
    if ASSIGNMENT.search(re.sub(r"\boperator\s*\S+", " ", flat)):
        return "other"
    # A lambda at namespace scope without `=` (a default member initialiser written with braces).
    if re.search(r"\]\s*(\(|\{|$)", flat.strip()):
        return "other"
    return "function"


def function_name(head):
    """The qualified name before the parameter list of a function's declaration."""
    m = re.search(r"([A-Za-z_~][\w:~]*(?:\s*<[^()]*>)?|operator\s*[^\s(]+)\s*\(",
                  strip_template_prefix(head))
    return re.sub(r"\s+", "", m.group(1)) if m else "?"


def strip_template_prefix(head):
    """The head without a leading `template <...>`."""
    m = re.match(r"\s*template\s*<", head)
    if not m:
        return head
    depth, k = 1, m.end()
    while k < len(head) and depth:
        depth += {"<": 1, ">": -1}.get(head[k], 0)
        k += 1
    return head[k:]


def functions(code):
    """(open index, close index, name) of every function body in the blanked code."""
    found = []

    def scan(start, end):
        head_start = start
        k = start
        while k < end:
            c = code[k]
            if c in ";}":
                head_start = k + 1
            elif c == ":" and code[k - 1] != ":" and k + 1 < end and code[k + 1] != ":" and \
                    re.search(r"\b(public|private|protected)\s*$", code[head_start:k]):
                head_start = k + 1
            elif c == "{":
                head = code[head_start:k]
                kind = classify(head)
                close = matching(code, k)
                if kind == "container":
                    scan(k + 1, close)
                elif kind == "function":
                    # A constructor's member initialiser written with braces (a_{x}) is no body:
                    # the body's brace follows a `)` or `}`, an initialiser's follows a name.
                    params_end = head.find(")")
                    after = head[params_end + 1 :] if params_end >= 0 else ""
                    in_init_list = re.search(r"(?<!:):(?!:)", after) is not None
                    before = head.rstrip()[-1:] if head.strip() else ""
                    if in_init_list and (before.isalnum() or before in "_>"):
                        k = close + 1
                        continue
                    found.append((k, close, function_name(head)))
                head_start = close + 1
                k = close + 1
                continue
            k += 1

    scan(0, len(code))
    return found


def has_reason(lines, open_line):
    """Whether the comment lines directly above the declaration that ends on open_line (1-based)
    state why the function is long."""
    # Back from the brace to the first line of the declaration (a line ending a statement or a
    # block, or a blank line, ends the search), then through the comment block above it.
    k = open_line - 1
    while k > 0 and lines[k - 1].strip() and not lines[k - 1].lstrip().startswith("//") and \
            not lines[k - 1].rstrip().endswith((";", "}", "{")):
        k -= 1
    while k > 0 and lines[k - 1].lstrip().startswith("//"):
        if REASON.match(lines[k - 1]):
            return True
        k -= 1
    return False


def check_file(path, rel, list_all, problems, used):
    with open(path, encoding="utf-8", errors="replace") as f:
        text = f.read()
    lines = text.split("\n")
    count = len(lines) - 1 if text.endswith("\n") else len(lines)
    if count > MAX_FILE_LINES:
        used.add(rel)
    if count > MAX_FILE_LINES and (list_all or rel not in KNOWN_LONG_FILES):
        problems.append(f"{rel}:1: {count} lines (more than {MAX_FILE_LINES}: split it by "
                        "capability)")
    if not rel.endswith(CPP_SUFFIXES):
        return
    code = blank_code(text)
    for open_at, close_at, name in functions(code):
        first = code.count("\n", 0, open_at) + 1
        last = code.count("\n", 0, close_at) + 1
        length = last - first + 1
        if length <= MAX_FUNCTION_LINES:
            continue
        reasoned = has_reason(lines, first)
        known = f"{rel}:{name}" in KNOWN_LONG_FUNCTIONS
        used.add(f"{rel}:{name}")
        if list_all or not (reasoned or known):
            note = " (reason stated)" if reasoned else " (known)" if known else ""
            problems.append(f"{rel}:{first}: {name}: {length} lines (more than "
                            f"{MAX_FUNCTION_LINES}){note}")


def main(argv):
    args = [a for a in argv[1:] if not a.startswith("--")]
    list_all = "--list" in argv
    root = os.path.abspath(args[0] if args else ".")
    problems = []
    used = set()
    checked = 0
    for top in SOURCE_DIRS:
        for dirpath, dirnames, filenames in os.walk(os.path.join(root, top)):
            dirnames.sort()
            for name in sorted(filenames):
                if not (name.endswith(SOURCE_SUFFIXES) or name == "CMakeLists.txt"):
                    continue
                path = os.path.join(dirpath, name)
                check_file(path, os.path.relpath(path, root), list_all, problems, used)
                checked += 1
    # The known list only shrinks: an entry that is no longer over the limit must go.
    for key in sorted((set(KNOWN_LONG_FILES) | set(KNOWN_LONG_FUNCTIONS)) - used):
        if not os.path.exists(os.path.join(root, key.split(":")[0])):
            continue  # a made-up tree (the self-test)
        problems.append(f"{key}: listed as known but not over the limit: remove it from "
                        "check_sizes.py's known list")
    for line in problems:
        print(line)
    if problems and not list_all:
        print(f"check_sizes: {len(problems)} problem(s) in {checked} files; a long function "
              f"needs '// long: <reason>' on a comment line above it", file=sys.stderr)
        return 1
    if not problems:
        print(f"check_sizes: {checked} files, none over {MAX_FILE_LINES} lines and no function "
              f"over {MAX_FUNCTION_LINES} lines without a reason, but for the known list "
              f"({len(KNOWN_LONG_FILES)} files, {len(KNOWN_LONG_FUNCTIONS)} functions)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
