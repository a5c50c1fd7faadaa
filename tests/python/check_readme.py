"""bindings/python/README.md's round-trip example is examples/python/roundtrip.py's
code between its "# --- README begin ---" and "# --- README end ---" lines,
verbatim: the README's ```python block right after the line
"<!-- examples/python/roundtrip.py -->". The script is run by the test
python_example_roundtrip, so the README's code cannot rot.
    usage: check_readme.py <source dir>
"""
import itertools
import os
import sys

MARK = "<!-- examples/python/roundtrip.py -->"


def readme_block(text):
    lines = text.splitlines()
    try:
        i = lines.index(MARK)
    except ValueError:
        sys.exit("README.md: no line %r" % MARK)
    if i + 1 >= len(lines) or lines[i + 1] != "```python":
        sys.exit("README.md: the line after %r is not ```python" % MARK)
    try:
        end = lines.index("```", i + 2)
    except ValueError:
        sys.exit("README.md: the block after %r is not closed" % MARK)
    return lines[i + 2:end]


def script_block(text):
    lines = text.splitlines()
    try:
        begin = lines.index("# --- README begin ---")
        end = lines.index("# --- README end ---")
    except ValueError:
        sys.exit("roundtrip.py: no README begin/end lines")
    return lines[begin + 1:end]


def main():
    src = sys.argv[1]
    with open(os.path.join(src, "bindings", "python", "README.md"), encoding="utf-8") as f:
        readme = readme_block(f.read())
    with open(os.path.join(src, "examples", "python", "roundtrip.py"), encoding="utf-8") as f:
        script = script_block(f.read())
    if readme != script:
        for k, (a, b) in enumerate(itertools.zip_longest(readme, script)):
            if a != b:
                sys.exit("README.md's example differs from roundtrip.py at line %d of the block:\n"
                         "  README: %r\n  script: %r" % (k + 1, a, b))
    print("README example == roundtrip.py (%d lines)" % len(script))


if __name__ == "__main__":
    main()
