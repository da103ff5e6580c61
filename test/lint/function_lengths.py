#!/usr/bin/env python3
"""Fails when a function in modules/, apps/ or include/ is longer than 150 lines.

A function here is a body whose opening brace stands alone at column 0 (the project's
style for free functions and out-of-class members; in-class methods and lambdas count
towards the function that holds them) and runs to the next closing brace at column 0.
Usage: function_lengths.py SOURCE_ROOT [LIMIT]
"""
import os
import re
import sys

root = sys.argv[1]
limit = int(sys.argv[2]) if len(sys.argv) > 2 else 150
too_long = []
for top in ("modules", "apps", "include"):
    for folder, _, files in os.walk(os.path.join(root, top)):
        for name in sorted(files):
            if not name.endswith((".cpp", ".h", ".hpp")):
                continue
            path = os.path.join(folder, name)
            lines = open(path, encoding="utf-8").read().split("\n")
            i = 1
            while i < len(lines):
                previous = lines[i - 1]
                if lines[i] == "{" and not re.match(r"^(namespace|struct|class|enum|union|extern)\b", previous):
                    end = i
                    while end < len(lines) and lines[end] != "}":
                        end += 1
                    k = i - 1
                    while k > 0 and "(" not in lines[k]:
                        k -= 1
                    length = end - i + 1
                    if length > limit:
                        too_long.append("%s:%d: %s is %d lines (limit %d)" % (os.path.relpath(path, root), i + 1,
                                                                              lines[k].strip()[:60], length, limit))
                    i = end
                i += 1
for line in too_long:
    print(line)
sys.exit(1 if too_long else 0)
