#!/usr/bin/env python3
"""Fails when a lib/ folder includes a folder that docs/architecture.md does
not allow it to depend on, or when a program outside lib/ (examples/, bench/)
reaches into the library's internal headers; and when a unit test is not
named after the module it tests, tests/unit/<folder>_<module>.c with
<folder> a lib/ folder.

The allowed edges are the "depends on" column of the folder table in
docs/architecture.md: one row per `lib/<folder>/`, its direct dependencies
comma-separated (or a dash for none). Only quoted includes of the form
"<folder>/<file>" count; "hetinv/..." is the public API and always allowed.

usage: check_layering.py <source root>
       check_layering.py --self-test   (the checker must catch a planted edge)
"""
import pathlib
import re
import sys

ROW = re.compile(r"^\|\s*`lib/([a-z_]+)/`\s*\|[^|]*\|([^|]*)\|\s*$")
INCLUDE = re.compile(r'^\s*#\s*include\s+"([a-z_0-9]+)/[^"]+"', re.MULTILINE)


def allowed_edges(doc):
    table = {}
    for line in doc.read_text(encoding="utf-8").splitlines():
        m = ROW.match(line)
        if m:
            deps = m.group(2).strip()
            names = [] if deps in ("", "—", "-") else [d.strip(" `") for d in deps.split(",")]
            table[m.group(1)] = set(names)
    return table


def includes(folder):
    for src in sorted(folder.rglob("*")):
        if src.suffix in (".c", ".h"):
            for m in INCLUDE.finditer(src.read_text(encoding="utf-8", errors="replace")):
                yield src, m.group(1)


def main(root):
    root = pathlib.Path(root)
    table = allowed_edges(root / "docs" / "architecture.md")
    folders = sorted(p.name for p in (root / "lib").iterdir() if p.is_dir())
    errors = []
    for name in folders:
        if name not in table:
            errors.append(f"lib/{name}/ has no row in docs/architecture.md's folder table")
    for name, deps in table.items():
        for dep in deps - set(folders):
            errors.append(f"docs/architecture.md: lib/{name}/ depends on '{dep}', which is not a lib/ folder")
    edges = 0
    for name in folders:
        for src, target in includes(root / "lib" / name):
            if target in ("hetinv", name) or target not in folders:
                continue
            edges += 1
            if target not in table.get(name, set()):
                errors.append(f"{src.relative_to(root)}: includes {target}/, but docs/architecture.md "
                              f"lets lib/{name}/ depend only on: {', '.join(sorted(table.get(name, ()))) or 'nothing'}")
    for outside in ("examples", "bench"):
        for src, target in includes(root / outside):
            if target in folders:
                errors.append(f"{src.relative_to(root)}: includes the library's internal {target}/; "
                              "programs use the public API (hetinv/...) only")
    unit = root / "tests" / "unit"
    tests = sorted(unit.glob("*.c")) if unit.is_dir() else []
    for src in tests:
        folder = src.stem.split("_", 1)[0]
        if folder not in folders or "_" not in src.stem:
            errors.append(f"{src.relative_to(root)}: a unit test is named <folder>_<module>.c after the module "
                          f"it tests, <folder> one of: {', '.join(folders)}")
    for e in errors:
        print(e)
    print(f"layering: {len(folders)} folders, {edges} cross-folder includes checked, {len(tests)} unit tests' "
          f"names checked, {len(errors)} violations")
    return 1 if errors else 0


def self_test():
    import tempfile
    with tempfile.TemporaryDirectory() as tmp:
        root = pathlib.Path(tmp)
        (root / "docs").mkdir()
        (root / "docs" / "architecture.md").write_text(
            "| folder | job | depends on |\n|---|---|---|\n"
            "| `lib/low/` | x | — |\n| `lib/high/` | y | low |\n", encoding="utf-8")
        for name, text in (("low", '#include "high/h.h"\n'), ("high", '#include "low/l.h"\n')):
            (root / "lib" / name).mkdir(parents=True)
            (root / "lib" / name / "a.c").write_text(text, encoding="utf-8")
        (root / "examples").mkdir()
        (root / "examples" / "p.c").write_text('#include "low/l.h"\n', encoding="utf-8")
        (root / "bench").mkdir()
        if main(root) != 1:
            print("self-test: the planted edges low -> high and examples -> low were not caught")
            return 1
        for name in ("low", "high"):
            (root / "lib" / name / "a.c").write_text("", encoding="utf-8")
        (root / "examples" / "p.c").write_text("", encoding="utf-8")
        (root / "tests" / "unit").mkdir(parents=True)
        (root / "tests" / "unit" / "low_a.c").write_text("", encoding="utf-8")
        if main(root) != 0:
            print("self-test: a clean tree was refused")
            return 1
        (root / "tests" / "unit" / "test_a.c").write_text("", encoding="utf-8")
        if main(root) != 1:
            print("self-test: the planted unit test name test_a.c was not caught")
            return 1
    print("self-test: planted edges and a misnamed unit test caught")
    return 0


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--self-test":
        sys.exit(self_test())
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else "."))
