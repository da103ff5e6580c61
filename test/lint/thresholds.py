#!/usr/bin/env python3
"""Fails when one threshold is written as a literal in two files (issue 42).

A threshold here is a named value given by a literal: a Config field's default in a
header (`float max_depth_jump = 0.02f;`, `c.max_depth_jump = 0.02f;` in a header's
function, or a default argument) or a named constant
(`constexpr float kSameSurface = 0.02f;`) in modules/ or include/. When the same name
(without a leading k, case-insensitive) has the same value in two files, the value has
two homes and will drift apart: give it one (a named constant the others use, or one
Config embedded in the other) instead. Names that are not thresholds (file format
versions, the work split of parallel loops) are listed in NOT_THRESHOLDS with why.
Usage: thresholds.py SOURCE_ROOT
"""
import collections
import os
import re
import sys

# name (lower case, without a leading k) -> why equal values in two files are no repetition
NOT_THRESHOLDS = {
    "version": "each file format counts its own versions",
    "rowsperchunk": "how a parallel loop splits its rows, chosen per loop",
}

TYPE = r"(?:static\s+)?(?:constexpr\s+|const\s+)*(?:float|double|int|unsigned|long|std::size_t|std::uint\d+_t|std::int\d+_t|size_t|bool)"
NUMBER = r"(-?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?)[fFuUlL]*"
FIELD = re.compile(r"^\s*" + TYPE + r"\s+(\w+)\s*=\s*" + NUMBER + r"\s*;")
CONSTANT = re.compile(r"\bconstexpr\s+[\w:]+\s+(k[A-Z]\w*)\s*=\s*" + NUMBER + r"\s*;")
MEMBER = re.compile(r"\b\w+\.(\w+)\s*=\s*" + NUMBER + r"\s*;")
ARGUMENT = re.compile(r"[(,]\s*(?:float|double|int|std::size_t)\s+(\w+)\s*=\s*" + NUMBER + r"\s*(?=[,)])")


def key(name):
    name = name.lower()
    return name[1:] if name.startswith("k") and len(name) > 1 else name


def homes(root):
    found = collections.defaultdict(set)
    for top in ("modules", "include"):
        for folder, _, files in os.walk(os.path.join(root, top)):
            for file in sorted(files):
                if not file.endswith((".cpp", ".h", ".hpp")):
                    continue
                path = os.path.join(folder, file)
                header = file.endswith((".h", ".hpp"))
                for number, line in enumerate(open(path, encoding="utf-8"), 1):
                    code = line.split("//")[0]
                    matches = list(CONSTANT.finditer(code))
                    if header:
                        matches += list(FIELD.finditer(code)) + list(MEMBER.finditer(code)) + list(ARGUMENT.finditer(code))
                    for m in matches:
                        value = float(m.group(2))
                        if value in (0.0, 1.0, -1.0) or key(m.group(1)) in NOT_THRESHOLDS:
                            continue
                        found[(key(m.group(1)), value)].add((os.path.relpath(path, root), number))
    return found


def main():
    repeated = []
    for (name, value), places in sorted(homes(sys.argv[1]).items()):
        if len({path for path, _ in places}) > 1:
            repeated.append("%s = %g in %s" % (name, value, ", ".join("%s:%d" % p for p in sorted(places))))
    for line in repeated:
        print("threshold written twice: " + line)
    return 1 if repeated else 0


if __name__ == "__main__":
    sys.exit(main())
