#!/usr/bin/env python3
"""Fails when a C++ source file of the project does not start with the licence's SPDX line.

The convention (README, "Licence"): every .h/.hpp/.cpp under include/, modules/, apps/,
examples/, fuzz/, bench/ and test/ starts with `// SPDX-License-Identifier: BSD-3-Clause`,
the licence of LICENSE at the top of the tree.
Usage: licence_headers.py SOURCE_ROOT
"""
import os
import sys

root = sys.argv[1]
LINE = "// SPDX-License-Identifier: BSD-3-Clause"
missing = []
if not os.path.isfile(os.path.join(root, "LICENSE")):
    missing.append("LICENSE: missing")
for top in ("include", "modules", "apps", "examples", "fuzz", "bench", "test", "python"):
    for folder, _, files in os.walk(os.path.join(root, top)):
        for name in sorted(files):
            if name.endswith((".cpp", ".h", ".hpp")):
                path = os.path.join(folder, name)
                with open(path, encoding="utf-8") as f:
                    if f.readline().rstrip("\n") != LINE:
                        missing.append("%s: first line is not '%s'" % (os.path.relpath(path, root), LINE))
for line in missing:
    print(line)
sys.exit(1 if missing else 0)
