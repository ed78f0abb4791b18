#!/usr/bin/python3
"""No production function longer than 120 lines (docs/design.md "Code style").

    /usr/bin/python3 tests/check_function_length.py SOURCE_DIR [--list]

Reads every .cpp and .hpp file of core/, parallel/, io/ and apps/ (formatted by clang-format,
so a function's body opens at the end of its header's last line and closes with a '}' at the
header's indentation). A function's length is the count of lines from its header to its
closing brace. The SIMD pair kernels of core/forces.cpp are exempt (their length is their
nature, said there): a function is exempt when a comment line directly above its header
contains "function-length: exempt". Exit 1 naming every longer function; --list prints the
20 longest whatever their length.
"""
import os
import re
import sys

LIMIT = 120
FOLDERS = ("core", "parallel", "io", "apps")
NOT_FUNCTION = re.compile(r"^\s*(namespace|class|struct|union|enum|extern|if|else|for|while|do|switch|try|catch)\b")
EXEMPT = "function-length: exempt"


def strip(line):
    """The line without string and character literals and // comments (braces in them ignored)."""
    line = re.sub(r'"(\\.|[^"\\])*"', '""', line)
    line = re.sub(r"'(\\.|[^'\\])*'", "''", line)
    return line.split("//", 1)[0]


def functions(path):
    with open(path, encoding="utf-8") as f:
        lines = f.read().split("\n")
    out = []
    i = 0
    in_block_comment = False
    while i < len(lines):
        code = strip(lines[i])
        if in_block_comment:
            if "*/" in code:
                in_block_comment = False
            i += 1
            continue
        if "/*" in code and "*/" not in code:
            in_block_comment = True
            i += 1
            continue
        stripped = code.rstrip()
        indent = len(lines[i]) - len(lines[i].lstrip())
        # A header ends with '{' at indentation 0 (namespace scope) or 2 (a member in a class).
        if stripped.endswith("{") and indent in (0, 2) and not stripped.lstrip().startswith("}"):
            # Collect the header: this line and the ones above it back to a ';', '}', '{' or blank.
            start = i
            while start > 0:
                prev = strip(lines[start - 1]).strip()
                if not prev or prev.endswith((";", "}", "{", ":")) or lines[start - 1].lstrip().startswith(("//", "#")):
                    break
                start -= 1
            header = " ".join(strip(lines[k]).strip() for k in range(start, i + 1))
            if "(" in header and not NOT_FUNCTION.match(header) and "=" not in header.split("(")[0]:
                depth = 0
                end = i
                for k in range(i, len(lines)):
                    c = strip(lines[k])
                    depth += c.count("{") - c.count("}")
                    if depth <= 0:
                        end = k
                        break
                name = re.sub(r"\s+", " ", header.split("(")[0]).strip().split(" ")[-1]
                exempt = start > 0 and EXEMPT in lines[start - 1]
                out.append((end - start + 1, name, start + 1, exempt))
                i = end + 1
                continue
        i += 1
    return out


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    root = sys.argv[1]
    found = []
    for folder in FOLDERS:
        for d, _, names in os.walk(os.path.join(root, folder)):
            for n in sorted(names):
                if n.endswith((".cpp", ".hpp")):
                    path = os.path.join(d, n)
                    for length, name, line, exempt in functions(path):
                        found.append((length, os.path.relpath(path, root), line, name, exempt))
    found.sort(reverse=True)
    if "--list" in sys.argv:
        for length, path, line, name, exempt in found[:20]:
            print(f"{length:5d}  {path}:{line}  {name}{'  (exempt)' if exempt else ''}")
    long = [f for f in found if f[0] > LIMIT and not f[4]]
    for length, path, line, name, _ in long:
        print(f"{path}:{line}: {name} is {length} lines (at most {LIMIT})")
    print(f"{len(found)} functions read, {len(long)} longer than {LIMIT} lines")
    sys.exit(1 if long else 0)


if __name__ == "__main__":
    main()
