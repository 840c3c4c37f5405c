#!/usr/bin/env python3
"""The layers of docs/DESIGN.md ("Layout"), checked on every #include of the library's sources.

A file may include its own folder and the folders below it; nothing above and nothing beside.
The three method folders (bubble, psys, peers) stand side by side: none includes another.
Public headers (<packmesh/...>) may be included anywhere.

The comparison engine (compare/src, the library packmesh_compare) sits between the library and
the command: cli -> compare -> libpackmesh. Besides the order of LAYERS, which implies it, this
is checked edge by edge, so that no reordering of the list can let it slip:
  - compare/src includes nothing of src/cli;
  - no file of the library (src/ but src/cli) includes compare;
  - compare/src uses libpackmesh through <packmesh/packmesh.h> and src/common, not src/api's
    internal headers;
  - outside compare/src, the engine is included through its public header only
    ("compare/src/compare.h"; study.h is the engine's own).
The command (src/cli) includes its own files and the engine's public header only: it uses the
library through <packmesh/packmesh.h> and <packmesh/packmesh_extended.h>.
The Python module's C extension (python/src) stands beside the command and includes its own
files only: it too uses the library through those two public headers.
A header named without a folder must lie beside the file that includes it.

Exit status 1 lists every offending line as FILE:LINE: FROM includes TO (above / beside), or
the rule it breaks.

Usage: check_layers.py SOURCE_DIR
"""
import os
import re
import sys

# Lowest first. A folder may include the folders before it in this list.
LAYERS = [
    "base",      # errors, rng, hashing, atomic files, parameter tables, summaries
    "backends",  # CGAL, TetGen, Embree, gmsh behind C headers; the versions they report
    "geom",      # the cell complex, trimming, the analytic and CAD models
    "mesh",      # the mesh, its topology, element measures, files, checker, point-in-volume
    "sizing",    # size fields, feature sizes, the neighbour grid, node budgets
    "input",     # models and default sizes from a spec: files, case files, built-in cases
    "connect",   # per-face CDT, flips, the volume step
    "measure",   # quality, needles, two-sided distance
    "method",    # the interface every mesher implements
    ("bubble", "psys", "peers"),  # the meshers, side by side
    "report",    # stats, trace, frames: above the methods, which report through observers
    "api",       # the public C API (include/packmesh) and what only it does
    "compare",   # the comparison engine
    ("cli", "python"),  # the packmesh command; the Python module's C extension (python/src)
]

# The one header of the comparison engine that files outside compare/src may include.
COMPARE_PUBLIC = "compare/src/compare.h"

RANK = {}
for i, layer in enumerate(LAYERS):
    for name in (layer if isinstance(layer, tuple) else (layer,)):
        RANK[name] = i

INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"')


def folder_of_file(rel):
    """The layer folder of a source file (path relative to the source dir), or None."""
    parts = rel.split(os.sep)
    if parts[0] == "src" and len(parts) >= 3:
        if parts[1] == "common" and len(parts) >= 4:
            return parts[2]
        return parts[1]
    if parts[0] == "compare" and len(parts) >= 3 and parts[1] == "src":
        return "compare"
    if parts[0] == "python" and len(parts) >= 3 and parts[1] == "src":
        return "python"
    return None


def folder_of_include(inc, own):
    parts = inc.split("/")
    if len(parts) == 1:
        return own  # a header of the same folder
    if parts[0] == "common" and len(parts) >= 3:
        return parts[1]
    return parts[0]


def rule_broken(own, to, inc):
    """The cli -> compare -> libpackmesh rule an include breaks, or None. The command sees the
    library through its public headers only, which are <...> includes and never checked here."""
    if own == "compare" and to == "cli":
        return "the comparison engine includes the command (cli -> compare, never back)"
    if own == "compare" and to == "api":
        return "the comparison engine includes src/api (use <packmesh/packmesh.h>)"
    if own not in ("compare", "cli") and to == "compare":
        return "the library includes the comparison engine (compare -> libpackmesh, never back)"
    if own == "cli" and to not in ("cli", "compare"):
        return ("the command includes the library's internals (it is built on "
                "<packmesh/packmesh.h> and <packmesh/packmesh_extended.h> only)")
    if own == "python" and to != "python":
        return ("the Python module includes the library's internals (it is built on "
                "<packmesh/packmesh.h> and <packmesh/packmesh_extended.h> only)")
    if own != "compare" and to == "compare" and inc != COMPARE_PUBLIC:
        return f"the comparison engine is included through {COMPARE_PUBLIC} only"
    return None


def main():
    if len(sys.argv) != 2:
        print("usage: check_layers.py SOURCE_DIR", file=sys.stderr)
        return 2
    root = sys.argv[1]
    bad, checked = [], 0
    for top in ("src", os.path.join("compare", "src"), os.path.join("python", "src")):
        for dirpath, _, files in os.walk(os.path.join(root, top)):
            for fn in sorted(files):
                if not fn.endswith((".c", ".h", ".cpp")):
                    continue
                path = os.path.join(dirpath, fn)
                rel = os.path.relpath(path, root)
                own = folder_of_file(rel)
                if own not in RANK:
                    bad.append(f"{rel}: folder '{own}' is not a layer of check_layers.py")
                    continue
                with open(path, encoding="utf-8") as f:
                    for n, line in enumerate(f, 1):
                        m = INCLUDE.match(line)
                        if not m:
                            continue
                        checked += 1
                        inc = m.group(1)
                        if "/" not in inc and not os.path.isfile(os.path.join(dirpath, inc)):
                            bad.append(f"{rel}:{n}: includes \"{inc}\" without a folder, and it "
                                       "is not beside the file")
                            continue
                        to = folder_of_include(inc, own)
                        why = rule_broken(own, to, inc)
                        if why:
                            bad.append(f"{rel}:{n}: includes \"{inc}\": {why}")
                            continue
                        if to == own:
                            continue
                        if to not in RANK:
                            bad.append(f"{rel}:{n}: includes \"{inc}\" of unknown folder '{to}'")
                        elif RANK[to] > RANK[own]:
                            bad.append(f"{rel}:{n}: {own} includes {to} (above it)")
                        elif RANK[to] == RANK[own]:
                            bad.append(f"{rel}:{n}: {own} includes {to} (beside it)")
    for b in bad:
        print(b)
    print(f"check_layers: {checked} includes checked, {len(bad)} against the layers")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
