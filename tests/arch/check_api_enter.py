#!/usr/bin/env python3
"""Fails when a public function defined in lib/ (marked HETINV_API) does not
start with HV_API_ENTER(); — the statement that makes every failure below it,
in any helper, name that function (lib/core/error.h).

usage: check_api_enter.py <source root>
       check_api_enter.py --self-test   (the checker must catch a planted omission)
"""
import pathlib
import re
import sys
import tempfile

# A definition: HETINV_API, the signature (no ';' or '{'), then the body's '{'.
DEFINITION = re.compile(r"^HETINV_API\b([^;{]*?)\)\s*\{", re.MULTILINE | re.DOTALL)
NAME = re.compile(r"(hetinv_[a-z0-9_]+)\s*\(")
FIRST = re.compile(r"\s*HV_API_ENTER\(\);")


def missing(root):
    bad, count = [], 0
    for src in sorted((pathlib.Path(root) / "lib").rglob("*.c")):
        text = src.read_text(encoding="utf-8", errors="replace")
        for m in DEFINITION.finditer(text):
            count += 1
            name = NAME.search(m.group(1))
            if not FIRST.match(text, m.end()):
                line = text.count("\n", 0, m.start()) + 1
                bad.append(f"{src}:{line}: {name.group(1) if name else '?'} does not start with HV_API_ENTER();")
    return bad, count


def main(root):
    bad, count = missing(root)
    for b in bad:
        print(b)
    if count == 0:
        print("no HETINV_API definitions found under", root)
        return 1
    print(f"{count} public definitions, {len(bad)} without HV_API_ENTER")
    return 1 if bad else 0


def self_test():
    with tempfile.TemporaryDirectory() as d:
        (pathlib.Path(d) / "lib" / "x").mkdir(parents=True)
        (pathlib.Path(d) / "lib" / "x" / "x.c").write_text(
            "HETINV_API int hetinv_good(void) {\n  HV_API_ENTER();\n  return 0;\n}\n"
            "HETINV_API int hetinv_bad(int a,\n                          int b) { return a + b; }\n")
        bad, count = missing(d)
        ok = count == 2 and len(bad) == 1 and "hetinv_bad" in bad[0]
        print("self-test", "passed" if ok else f"FAILED: {count} definitions, {bad}")
        return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(self_test() if sys.argv[1:] == ["--self-test"] else main(sys.argv[1]))
