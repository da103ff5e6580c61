#!/usr/bin/env python3
"""Fails when a document, script or source file of the project names a path outside it.

Readers of the repository have nothing beside it: the design, the reference's summary and
the benchmarks' data paths live in docs/ or are given on the command line (issue 40).
Checked: every file under the tree (build folders and .git left out) whose name ends in
.md, .py, .sh, .cpp, .h, .hpp, .txt, .cmake, .json or has no extension, for a relative
path that climbs out of the repository into a sibling folder ("../shared", "../../data").
Usage: no_outside_paths.py SOURCE_ROOT
"""
import os
import re
import sys

root = os.path.abspath(sys.argv[1])
SKIP = {".git", "build", "build-sanitize", "build-fuzz", "test-fixtures"}
EXTENSIONS = (".md", ".py", ".sh", ".cpp", ".h", ".hpp", ".txt", ".cmake", ".json", ".in", ".yml")
# A relative path that starts with "../" (not the tail of $DATA/../tools) is out of the
# tree when, read from the top of the tree (as commands in the docs are), it climbs out of
# it, and read from the file's own folder it climbs out or names nothing there (a page in
# docs/ may link ../README.md).
pattern = re.compile(r"(?<![\w$/.-])(?:\.\./)+([A-Za-z0-9_.-]+)")
found = []
for folder, dirs, files in os.walk(root):
    dirs[:] = [d for d in dirs if d not in SKIP and not d.startswith("build")]
    for name in files:
        if not (name.endswith(EXTENSIONS) or "." not in name):
            continue
        path = os.path.join(folder, name)
        if os.path.abspath(path) == os.path.abspath(__file__):
            continue  # its own examples
        try:
            text = open(path, encoding="utf-8").read()
        except (UnicodeDecodeError, OSError):
            continue
        for number, line in enumerate(text.split("\n"), 1):
            for match in pattern.finditer(line):
                from_top = os.path.normpath(os.path.join(root, match.group(0)))
                from_here = os.path.normpath(os.path.join(folder, match.group(0)))
                inside = lambda p: (p + os.sep).startswith(root + os.sep)
                if not inside(from_top) and (not inside(from_here) or not os.path.exists(from_here)):
                    found.append("%s:%d: %s" % (os.path.relpath(path, root), number, line.strip()[:100]))
for line in found:
    print(line)
sys.exit(1 if found else 0)
