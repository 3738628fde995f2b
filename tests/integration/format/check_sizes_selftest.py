#!/usr/bin/env python3
"""check_sizes.py must catch a long file and a long function without a reason, and must not be
fooled by lambdas, namespaces, classes, initialisers, comments or strings: runs it on small
made-up trees. usage: check_sizes_selftest.py PATH/TO/check_sizes.py"""

import os
import subprocess
import sys
import tempfile

checker = sys.argv[1]
failures = 0


def body(n):
    return "".join(f"  x += {i};\n" for i in range(n))


def expect(code, name, files):
    global failures
    with tempfile.TemporaryDirectory() as root:
        for rel, text in files.items():
            path = os.path.join(root, rel)
            os.makedirs(os.path.dirname(path), exist_ok=True)
            with open(path, "w") as f:
                f.write(text)
        run = subprocess.run([sys.executable, checker, root], capture_output=True, text=True)
    if run.returncode != code:
        print(f"FAIL: {name}: exit {run.returncode}, expected {code}\n{run.stdout}{run.stderr}")
        failures += 1
    else:
        print(f"ok: {name}")


short = "int f(int x) {\n" + body(70) + "  return x;\n}\n"
long_fn = "int f(int x) {\n" + body(85) + "  return x;\n}\n"
expect(0, "short functions pass", {"services/a/a.cpp": short})
expect(1, "a long function", {"services/a/a.cpp": "namespace n {\n" + long_fn + "}\n"})
expect(0, "a long function with a reason",
       {"services/a/a.cpp": "// Adds.\n// long: one table of cases, read top to bottom\n" + long_fn})
expect(1, "a reason that is not directly above",
       {"services/a/a.cpp": "// long: why\nint g() { return 1; }\n\n" + long_fn})
expect(1, "a long member function inside a class in a namespace",
       {"tools/t/a.hpp": "namespace n {\nclass A : public B {\n public:\n  " +
                         long_fn.replace("\n", "\n  ") + "};\n}\n"})
expect(1, "a long constructor with braced member initialisers",
       {"tools/t/a.cpp": "A::A(int x) : a_{x}, b_(x) {\n" + body(85) + "}\n"})
expect(0, "a long lambda assigned at namespace scope is no function",
       {"tools/t/a.cpp": "namespace {\nconst auto f = [](int x) {\n" + body(85) + "  return x;\n};\n}\n"})
expect(1, "a lambda inside a function counts towards it",
       {"tools/t/a.cpp": "void f() {\n  auto g = [&] {\n" + body(50) + "  };\n" +
                         "  auto h = [&] {\n" + body(40) + "  };\n}\n"})
expect(0, "a long braced initialiser is no function",
       {"common/c/a.cpp": "const std::array<int, 90> kTable{\n" +
                          "".join(f"    {i},\n" for i in range(90)) + "};\n"})
expect(0, "braces in comments, strings, characters and digit separators are not counted",
       {"common/c/a.cpp": "int f() {\n  // }\n  const char* s = \"}}\";\n  char c = '}';\n" +
                          "  int n = 1'000;\n  auto r = R\"(}})\";\n" + body(60) + "}\n" + short})
expect(1, "a file over 700 lines", {"tools/t/a.cpp": "// line\n" * 701})
expect(0, "a test file over 700 lines", {"tests/unit/a_test.cpp": "// line\n" * 701})
sys.exit(1 if failures else 0)
