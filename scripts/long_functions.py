#!/usr/bin/env python3
"""Functions longer than N lines (default 100) in the workspace's Rust files, longest first
(`--no-tests`: leaving out `tests/` folders and `tests.rs` files).

A function runs from its `fn` line to the closing brace at the same indentation.

    python3 scripts/long_functions.py [N] [--no-tests]
"""
import os
import re
import sys

limit = int(next((a for a in sys.argv[1:] if a.isdigit()), 100))
skip_tests = "--no-tests" in sys.argv
pat = re.compile(r'^(\s*)(pub(\([a-z]+\))? )?(const )?(unsafe )?(extern "C" )?fn ([a-zA-Z0-9_]+)')
found = []
for root, dirs, files in os.walk("."):
    dirs[:] = [d for d in dirs if d not in ("target", ".git")]
    if skip_tests and "/tests" in root:
        continue
    for f in files:
        if not f.endswith(".rs") or (skip_tests and f == "tests.rs"):
            continue
        path = os.path.join(root, f)
        lines = open(path).read().split("\n")
        for i, line in enumerate(lines):
            m = pat.match(line)
            if not m or line.rstrip().endswith(";"):
                continue
            indent = m.group(1)
            for j in range(i + 1, len(lines)):
                if lines[j].startswith(indent + "}") and lines[j].strip() in ("}", "};", "})", "},"):
                    break
            else:
                continue
            if j - i + 1 > limit:
                found.append((j - i + 1, path, m.group(7)))
for n, path, name in sorted(found, reverse=True):
    print(n, path, name)
