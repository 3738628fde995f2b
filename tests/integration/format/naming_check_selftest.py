#!/usr/bin/env python3
"""naming_check.py must catch a badly named member in a header and in a source file's own type,
and pass a clean tree: runs it on small made-up trees with the repository's .clang-tidy.

usage: naming_check_selftest.py PATH/TO/naming_check.py REPO_ROOT
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile

CLEAN_HEADER = """#pragma once
namespace x {
struct Options {
  int cell_size = 4;
};
class Counter {
 public:
  int count() const { return count_; }
 private:
  int count_ = 0;
};
}  // namespace x
"""
CLEAN_SOURCE = """#include "common/x/options.hpp"
namespace {
struct Local {
  int frame_count = 0;
};
}  // namespace
int useIt() { return Local{}.frame_count + x::Options{}.cell_size; }
"""


def make_tree(root, header, source):
    os.makedirs(os.path.join(root, "common", "x"))
    os.makedirs(os.path.join(root, "build"))
    shutil.copy(os.path.join(sys.argv[2], ".clang-tidy"), root)
    with open(os.path.join(root, "common", "x", "options.hpp"), "w") as out:
        out.write(header)
    with open(os.path.join(root, "common", "x", "use.cpp"), "w") as out:
        out.write(source)
    entry = {"directory": os.path.join(root, "build"), "file": os.path.join(root, "common/x/use.cpp"),
             "command": f"c++ -std=c++20 -I{root} -c {root}/common/x/use.cpp"}
    with open(os.path.join(root, "build", "compile_commands.json"), "w") as out:
        json.dump([entry], out)


def expect(code, name, header, source, must_name=None):
    with tempfile.TemporaryDirectory() as root:
        make_tree(root, header, source)
        proc = subprocess.run([sys.executable, sys.argv[1], root, os.path.join(root, "build")],
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    ok = proc.returncode == code and (must_name is None or must_name in proc.stdout)
    print(("ok: " if ok else "FAIL: ") + name)
    if not ok:
        print(f"  exit {proc.returncode}, expected {code}; output:\n{proc.stdout}")
    return ok


def main():
    if len(sys.argv) != 3:
        print(__doc__)
        return 2
    if shutil.which("clang-tidy") is None:
        print("clang-tidy is not installed: skipped")
        return 77
    results = [
        expect(0, "a clean tree passes", CLEAN_HEADER, CLEAN_SOURCE),
        expect(1, "a camelCase public member in a header",
               CLEAN_HEADER.replace("int cell_size", "int cellSize"),
               CLEAN_SOURCE.replace(".cell_size", ".cellSize"), "'cellSize'"),
        expect(1, "a private member without the trailing underscore",
               CLEAN_HEADER.replace("count_", "count_value"), CLEAN_SOURCE, "'count_value'"),
        expect(1, "a camelCase member of a source file's own struct", CLEAN_HEADER,
               CLEAN_SOURCE.replace("frame_count", "frameCount"), "'frameCount'"),
        expect(1, "a protected member of a source file's class with a trailing underscore",
               CLEAN_HEADER, CLEAN_SOURCE + "class Fixture {\n protected:\n  int dir_ = 0;\n};\n",
               "'dir_'"),
        expect(1, "a camelCase member of a source file's class after a nested struct, a member "
               "function with nested blocks and a string holding //", CLEAN_HEADER,
               CLEAN_SOURCE + "class Fixture {\n protected:\n  struct Sim {\n    int a = 0;\n  };\n"
               "  int f(int n) {\n    for (int i = 0; i < n; ++i) {\n      if (i) {\n        n += i;\n"
               "      }\n    }\n    return n;\n  }\n  const char* url = \"memq://\";\n"
               "  int frameCount = 0;\n};\n", "'frameCount'"),
        expect(1, "a header that does not compile",
               CLEAN_HEADER + "inline int broken() { return undeclared; }\n", CLEAN_SOURCE),
        expect(1, "a source file with a suspect member that does not compile", CLEAN_HEADER,
               CLEAN_SOURCE.replace("frame_count", "frameCount") + "int broken() { return undeclared; }\n"),
    ]
    return 0 if all(results) else 1


if __name__ == "__main__":
    sys.exit(main())
