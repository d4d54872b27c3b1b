#!/usr/bin/env python3
"""The parts of server/ and who may include whom (docs/architecture.md).

Every `#include "part/..."` in server/PART/ must name PART itself or a part
PART may use. A part that is not in the table, or an include of one that is
not allowed, fails with the file, the line and the rule it breaks. The table
is the CMake link graph written out: a new dependency is a decision, made here
and in docs/architecture.md together.

  layers.py [SERVER_DIR]
"""
import os
import re
import sys

# part -> the parts it may include (besides itself and common/).
ALLOWED = {
    "common": set(),
    "spirv": set(),
    "gpu": {"spirv"},
    "scenes": set(),
    "renderers": {"gpu", "scenes", "spirv"},
    "analysis": set(),
    "sweeps": {"analysis", "renderers", "gpu", "scenes", "spirv"},
    "capture": {"sweeps", "analysis", "renderers", "gpu", "scenes", "spirv"},
    "store": set(),
    "api": set(),
    "jobs": {"store"},
    # reports: computed from stored runs, without Vulkan (scenes: a heatmap's plan from the scene's triangles).
    "reports": {"store", "analysis", "scenes"},
    "service": {"api", "store", "reports", "capture", "sweeps", "analysis"},
    "commands": {"service", "api", "store", "reports", "jobs", "capture", "sweeps", "analysis", "renderers", "scenes",
                 "spirv", "gpu"},
}
# Files directly in server/ (main.cpp, protocol.hpp): the executable's own.
TOP = {"commands", "service", "api", "store", "reports", "jobs", "capture", "sweeps", "analysis", "renderers", "scenes",
       "spirv", "gpu"}

# layer/ (the Vulkan layer, a shared library loaded into other processes)
# beside server/: the SPIR-V library only, no Vulkan loader, no daemon part.
LAYER_ALLOWED = {"spirv", "common"}

INCLUDE = re.compile(r'^\s*#\s*include\s+"([a-z_]+)/')


def check(server):
    errors = []
    parts = {d for d in os.listdir(server) if os.path.isdir(os.path.join(server, d))}
    for unknown in sorted(parts - ALLOWED.keys()):
        errors.append(f"server/{unknown}/: a part not in the layer table (tests/layout/layers.py)")
    for root, _, files in os.walk(server):
        rel = os.path.relpath(root, server)
        part = rel.split(os.sep)[0] if rel != "." else None
        allowed = TOP if part is None else ALLOWED.get(part, set())
        for name in sorted(files):
            if not name.endswith((".cpp", ".hpp", ".h", ".in")):
                continue
            path = os.path.join(root, name)
            with open(path, encoding="utf-8") as f:
                for number, line in enumerate(f, 1):
                    m = INCLUDE.match(line)
                    if not m:
                        continue
                    target = m.group(1)
                    if target not in ALLOWED or target in ("common", part):
                        continue  # a system or shader header, common/, or the part itself
                    if target not in allowed:
                        who = f"server/{part}" if part else "server/"
                        errors.append(f"{os.path.relpath(path, os.path.dirname(server))}:{number}: "
                                      f"{who} may not include {target}/ (allowed: {', '.join(sorted(allowed)) or 'common only'})")
    layer = os.path.join(os.path.dirname(server), "layer")
    if os.path.isdir(layer):
        for name in sorted(os.listdir(layer)):
            if not name.endswith((".cpp", ".hpp")):
                continue
            with open(os.path.join(layer, name), encoding="utf-8") as f:
                for number, line in enumerate(f, 1):
                    m = INCLUDE.match(line)
                    if m and m.group(1) in ALLOWED and m.group(1) not in LAYER_ALLOWED:
                        errors.append(f"layer/{name}:{number}: layer/ may not include {m.group(1)}/ "
                                      f"(allowed: {', '.join(sorted(LAYER_ALLOWED))})")
    return errors


def page_table(page):
    """The "may use" column of docs/architecture.md's table of parts: part ->
    set of parts. "all of the above" is every part in the rows above; "—"
    is none; an item's first word is the part ("spirv (`footprint.hpp`
    only)" is spirv)."""
    table, order = {}, []
    for line in open(page, encoding="utf-8"):
        m = re.match(r"^\| `(\w+)/` \| [^|]+ \| .* \| ([^|]+) \|\s*$", line)
        if not m:
            continue
        part, uses = m.group(1), m.group(2).strip()
        if uses == "all of the above":
            table[part] = {p for p in order if p != "common"}
        elif uses in ("—", "-", ""):
            table[part] = set()
        else:
            table[part] = {item.strip().split()[0] for item in uses.split(",")}
        order.append(part)
    return table


def check_page(page):
    """The page and this script's table say the same."""
    errors = []
    table = page_table(page)
    for part in sorted(set(ALLOWED) | set(table)):
        if part not in table:
            errors.append(f"{page}: no row for part {part}/ (the layer table in tests/layout/layers.py has one)")
        elif part not in ALLOWED:
            errors.append(f"{page}: a row for {part}/, which tests/layout/layers.py does not have")
        elif table[part] != ALLOWED[part]:
            errors.append(f"{page}: {part}/ may use {', '.join(sorted(table[part])) or 'nothing'} there, "
                          f"but {', '.join(sorted(ALLOWED[part])) or 'nothing'} in tests/layout/layers.py")
    return errors


def main():
    server = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", "..", "server")
    errors = check(os.path.normpath(server))
    page = os.path.join(os.path.dirname(os.path.normpath(server)), "docs", "architecture.md")
    if os.path.exists(page):
        errors += check_page(page)
    for e in errors:
        print(e)
    if errors:
        return 1
    print(f"layers: {len(ALLOWED)} parts, every include allowed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
