#!/usr/bin/env python3
"""Tests of harden_lcm_decode.py: decoders shaped like lcm-gen 1.3.1's are hardened; a decoder it
cannot harden fails the run with a message naming the file and the array, and is deleted.
Usage: harden_lcm_decode_test.py [GENERATED_HEADER...]  (also re-checks already hardened headers)
"""
import pathlib
import subprocess
import sys
import tempfile

SCRIPT = pathlib.Path(__file__).with_name("harden_lcm_decode.py")

# The decoder shapes lcm-gen 1.3.1 writes: a primitive array, a string array, a string.
LIKE_1_3_1 = """int demo_t::_decodeNoHash(const void *buf, int offset, int maxlen)
{
    int pos = 0, tlen;

    if(this->count) {
        this->x.resize(this->count);
        tlen = __float_decode_array(buf, offset + pos, maxlen - pos, &this->x[0], this->count);
        if(tlen < 0) return tlen; else pos += tlen;
    }

    this->names.resize(this->count);
    for (int a0 = 0; a0 < this->count; a0++) {
        int32_t __elem_len;
        tlen = __int32_t_decode_array(buf, offset + pos, maxlen - pos, &__elem_len, 1);
        if(tlen < 0) return tlen; else pos += tlen;
        if(__elem_len > maxlen - pos) return -1;
        this->names[a0].assign(((const char*)buf) + offset + pos, __elem_len -  1);
        pos += __elem_len;
    }

    int32_t __label_len__;
    tlen = __int32_t_decode_array(buf, offset + pos, maxlen - pos, &__label_len__, 1);
    if(tlen < 0) return tlen; else pos += tlen;
    if(__label_len__ > maxlen - pos) return -1;
    this->label.assign(((const char*)buf) + offset + pos, __label_len__ - 1);
    pos += __label_len__;
    return pos;
}
"""

failures = []
# Every case writes into a folder of its own under one that is removed at exit (a build runs this
# test each time the generated headers change: left behind, its folders filled /tmp).
SCRATCH = tempfile.TemporaryDirectory(prefix="harden_lcm_decode_test_")


def check(condition, what):
    if not condition:
        failures.append(what)
        print("FAIL:", what)


def run(text, name):
    d = pathlib.Path(tempfile.mkdtemp(dir=SCRATCH.name))
    path = d / name
    path.write_text(text)
    r = subprocess.run([sys.executable, str(SCRIPT), str(path)], capture_output=True, text=True)
    return r, path


# 1. The 1.3.1 shapes: exit 0, every count and length checked, idempotent.
r, path = run(LIKE_1_3_1, "demo_t.hpp")
check(r.returncode == 0, "1.3.1-shaped decoder: exit {} ({})".format(r.returncode, r.stderr))
hardened = path.read_text() if path.exists() else ""
check(hardened.count("if(this->count < 0 || this->count > maxlen - pos) return -1;") == 2,
      "both resizes of `count` get their check")
check("if(__elem_len <= 0 || __elem_len > maxlen - pos) return -1;" in hardened,
      "string array element lengths below 1 are refused")
check("if(__label_len__ <= 0 || __label_len__ > maxlen - pos) return -1;" in hardened,
      "string lengths below 1 are refused")
r2 = subprocess.run([sys.executable, str(SCRIPT), str(path)], capture_output=True, text=True)
check(r2.returncode == 0 and path.read_text() == hardened, "a second run changes nothing")

# 2. Shapes another lcm-gen might write: each must fail loudly, naming file and array.
others = {
    "spaced_if": (LIKE_1_3_1.replace("if(this->count) {", "if (this->count) {"), "x"),
    "expression_count": (LIKE_1_3_1.replace("this->x.resize(this->count);",
                                            "this->x.resize(this->count * 2);"), "x"),
    "nested_array": (LIKE_1_3_1.replace("this->x.resize(this->count);",
                                        "this->x[a0].resize(this->count);"), "x[a0]"),
    "spaced_string_check": (LIKE_1_3_1.replace("if(__label_len__ > maxlen - pos)",
                                               "if (__label_len__ > maxlen - pos)"), "label"),
}
for name, (text, array) in others.items():
    r, path = run(text, name + ".hpp")
    check(r.returncode == 1, "{}: exit {}, want 1".format(name, r.returncode))
    check(str(path) in r.stderr and array in r.stderr,
          "{}: message names the file and `{}`: {!r}".format(name, array, r.stderr))
    check(not path.exists(), "{}: the unchecked header is deleted".format(name))

# 3. The headers of this build (already hardened), on copies: they pass unchanged.
for header in sys.argv[1:]:
    before = pathlib.Path(header).read_text()
    r, path = run(before, pathlib.Path(header).name)
    check(r.returncode == 0, "{}: exit {} ({})".format(header, r.returncode, r.stderr))
    check(path.exists() and path.read_text() == before, "{}: unchanged".format(header))

print("PASS" if not failures else "{} failures".format(len(failures)))
sys.exit(1 if failures else 0)
