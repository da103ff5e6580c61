#!/usr/bin/env python3
"""Fails when a module includes a header of a module it does not depend on (issue 42).

The layers are the table "module | depends on | holds" in docs/architecture.md. A module
may include its own headers and those of every module it depends on, directly or through
another (a module's public link dependencies come with it). Also fails when a module's
direct cuefusion:: dependencies in CMake (cuefusion_add_module(... DEPENDS ...)) are not
the ones the table names, so that the table stays true.
Which module a file belongs to: modules/<dir>/src/<stem>.cpp to the cuefusion_add_module
call in modules/<dir>/CMakeLists.txt that lists it (the viewer's live_viewer.cpp), else to
<dir>; a header include/cuefusion/<dir>/<stem>.h or modules/<dir>/src/<stem>.h to the
module of <stem>.cpp beside it when one call lists it, else to <dir>.
Usage: layers.py SOURCE_ROOT
"""
import os
import re
import sys

root = os.path.abspath(sys.argv[1])
problems = []

# The table.
deps = {}
with open(os.path.join(root, "docs", "architecture.md"), encoding="utf-8") as f:
    in_table = False
    for line in f:
        if line.startswith("| module | depends on |"):
            in_table = True
            continue
        if in_table:
            if not line.startswith("|"):
                break
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            if cells[0].startswith("---"):
                continue
            deps[cells[0]] = set() if cells[1] in ("—", "-", "") else {d.strip() for d in cells[1].split(",")}
if len(deps) < 5:
    sys.exit("layers.py: the module table in docs/architecture.md was not found")

def closure(module, seen=None):
    seen = set() if seen is None else seen
    for d in deps.get(module, ()):
        if d not in seen:
            seen.add(d)
            closure(d, seen)
    return seen

# CMake: which module lists which source, and its cuefusion:: dependencies.
owner = {}  # (dir, stem) -> module, for files a call names
cmake_deps = {}
call = re.compile(r"cuefusion_add_module\((\w+)(.*?)\)\s*$", re.S | re.M)
for d in sorted(os.listdir(os.path.join(root, "modules"))):
    path = os.path.join(root, "modules", d, "CMakeLists.txt")
    if not os.path.isfile(path):
        continue
    text = open(path, encoding="utf-8").read()
    for m in call.finditer(text):
        name, body = m.group(1), m.group(2)
        for src in re.findall(r"src/(\w+)\.cpp", body):
            owner[(d, src)] = name
        depends = body.split("DEPENDS", 1)[1] if "DEPENDS" in body else ""
        cmake_deps[name] = set(re.findall(r"cuefusion::(\w+)", depends))

for name, listed in cmake_deps.items():
    if name not in deps:
        problems.append(f"module {name} (CMake) is not in the table of docs/architecture.md")
    elif listed != deps[name]:
        problems.append(f"module {name}: CMake depends on {sorted(listed)}, the table says {sorted(deps[name])}")

def module_of(d, stem):
    return owner.get((d, stem), d)

include = re.compile(r'^\s*#\s*include\s*[<"]cuefusion/(\w+)/(?:impl/)?(\w+)\.h(?:pp)?[>"]', re.M)
files = []
for d in os.listdir(os.path.join(root, "modules")):
    src = os.path.join(root, "modules", d, "src")
    if os.path.isdir(src):
        files += [(d, os.path.join(src, n)) for n in os.listdir(src) if n.endswith((".cpp", ".h", ".hpp"))]
for d in os.listdir(os.path.join(root, "include", "cuefusion")):
    for folder, _, names in os.walk(os.path.join(root, "include", "cuefusion", d)):
        files += [(d, os.path.join(folder, n)) for n in names if n.endswith((".h", ".hpp"))]
checked = 0
for d, path in files:
    stem = os.path.splitext(os.path.basename(path))[0]
    module = module_of(d, stem)
    allowed = closure(module) | {module}
    for m in include.finditer(open(path, encoding="utf-8").read()):
        target = module_of(m.group(1), m.group(2))
        checked += 1
        if target not in allowed:
            problems.append(f"{os.path.relpath(path, root)} ({module}) includes cuefusion/{m.group(1)}/{m.group(2)} "
                            f"({target}), a module it does not depend on")
if checked < 100:
    problems.append(f"only {checked} includes were checked: the scan found too few files")
for p in problems:
    print(p)
sys.exit(1 if problems else 0)
