#!/bin/bash
# The installed library as a program that embeds packmesh sees it (issue: "install like a library"):
#   1. `cmake --install` into a fresh prefix: libpackmesh.so, packmesh.h, packmesh.pc, the CMake
#      package, the command, its man pages (packmesh(1) and one per command of `packmesh
#      --help`, under share/man/man1, where `man` finds them) and its bash completion (under
#      share/bash-completion/completions, completing `packmesh me` to mesh);
#   2. libpackmesh.so exports the public API only: every dynamic symbol is pm_*;
#   3. the four examples compile with nothing but `pkg-config --cflags --libs packmesh`, and run;
#      mesh_cad meshes case:qi3 with bubble to the node count `packmesh mesh case:qi3 --method
#      bubble` prints;
#   4. the examples build again through find_package(packmesh) in CMake;
#   5. when the build has the Python module: the installed package imports (PYTHONPATH = its site
#      folder under the prefix), loads the installed libpackmesh.so, meshes case:qi3 to the same
#      node count, and compare() runs the installed command.
# Usage: test_install.sh SOURCE_DIR BUILD_DIR [EXTRA_C_FLAGS [PYTHON]]
#   EXTRA_C_FLAGS: the sanitizer flags of the build; PYTHON: the python3 the module is built for
#   (empty: the build has no Python module).
set -euo pipefail
src=$1 build=$2 extra=${3:-} python=${4:-}
work=$(mktemp -d "${TMPDIR:-/tmp}/pm_install.XXXXXX")
trap 'rm -rf "$work"' EXIT
prefix=$work/prefix
fail() { echo "test_install: $*" >&2; exit 1; }

cmake --install "$build" --prefix "$prefix" >"$work/install.log" || { cat "$work/install.log"; fail "cmake --install failed"; }
lib=$(dirname "$(find "$prefix" -name 'libpackmesh.so' | head -1)")
[ -n "$lib" ] && [ -f "$lib/libpackmesh.so" ] || fail "no libpackmesh.so installed"
[ -f "$prefix/include/packmesh/packmesh.h" ] || fail "no packmesh.h installed"
[ -f "$prefix/include/packmesh/packmesh_extended.h" ] || fail "no packmesh_extended.h installed"
pc=$(find "$prefix" -name packmesh.pc | head -1)
[ -n "$pc" ] || fail "no packmesh.pc installed"
[ -n "$(find "$prefix" -name packmesh-config.cmake)" ] || fail "no CMake package installed"
[ -x "$prefix/bin/packmesh" ] || fail "no packmesh command installed"
echo "installed: $lib/libpackmesh.so, $pc"

# The man pages and the completion, beside the command.
man1=$prefix/share/man/man1
commands=$("$prefix/bin/packmesh" --help | awk '/^commands:/ { on = 1; next } on && NF == 0 { exit } on { print $1 }')
[ "$(echo "$commands" | wc -w)" -ge 6 ] || fail "packmesh --help lists too few commands: $commands"
for page in packmesh $(for c in $commands; do echo "packmesh-$c"; done); do
  [ -s "$man1/$page.1" ] || fail "no man page $page.1 installed in $man1"
done
if command -v man >/dev/null; then
  found=$(MANPATH=$prefix/share/man man -w packmesh-mesh) || fail "man -w packmesh-mesh finds no page under $prefix"
  [ "$found" = "$man1/packmesh-mesh.1" ] || fail "man -w packmesh-mesh gives $found"
fi
completion=$prefix/share/bash-completion/completions/packmesh
[ -s "$completion" ] || fail "no bash completion installed at $completion"
got=$(bash --norc -c 'source "$1" && COMP_WORDS=(packmesh me) COMP_CWORD=1 && _packmesh && echo "${COMPREPLY[*]}"' \
      bash "$completion") || fail "the installed completion does not load"
[ "$got" = mesh ] || fail "the installed completion completes 'packmesh me' to '$got'"
echo "installed: $(echo $commands | wc -w) commands' man pages and packmesh(1) in $man1, the completion $completion"

# 2. Only pm_* symbols leave the library.
others=$(nm -D --defined-only "$lib/libpackmesh.so" | awk '$3 != "" {print $3}' | sed 's/@.*//' \
         | grep -v '^pm_' | grep -v '^PACKMESH_' || true)
[ -z "$others" ] || fail "libpackmesh.so exports symbols outside the API: $(echo $others | head -c 400)"
nexp=$(nm -D --defined-only "$lib/libpackmesh.so" | grep -c ' pm_')
echo "exported: $nexp pm_* symbols, nothing else"

# 3. pkg-config only.
export PKG_CONFIG_PATH=$(dirname "$pc")
flags=$(pkg-config --cflags --libs packmesh)
for ex in mesh_cad compare_quality size_callback run_stats; do
  # shellcheck disable=SC2086
  cc -std=c11 -Wall -Wextra -Werror $extra "$src/examples/$ex.c" $flags -lm -Wl,-rpath,"$lib" \
     -o "$work/$ex" || fail "$ex does not compile with pkg-config --cflags --libs packmesh ($flags)"
done
out=$("$work/mesh_cad" case:qi3) || fail "mesh_cad case:qi3 failed: $out"
echo "example: $out"
cli=$("$prefix/bin/packmesh" mesh case:qi3 --method bubble -o "$work/qi3.msh") \
  || fail "packmesh mesh case:qi3 failed: $cli"
echo "command: $cli"
n_ex=$(echo "$out" | sed -n 's/.*: \([0-9]*\) nodes.*/\1/p')
n_cli=$(echo "$cli" | sed -n 's/.*: \([0-9]*\) nodes.*/\1/p')
[ -n "$n_ex" ] && [ "$n_ex" = "$n_cli" ] || fail "node counts differ: example $n_ex, command $n_cli"
out=$("$work/compare_quality" case:qi3) || fail "compare_quality failed: $out"
echo "$out"
[ "$(echo "$out" | grep -c 'radius ratio median 0\.[0-9]')" = 2 ] || fail "compare_quality printed: $out"
out=$("$work/size_callback") || fail "size_callback failed: $out"
echo "$out"
med=$(echo "$out" | sed -n 's/.*median \([0-9.]*\),.*/\1/p')
awk -v m="$med" 'BEGIN { exit !(m > 0.8 && m < 1.25) }' || fail "size_callback: edges do not follow the field (median $med)"
out=$("$work/run_stats" case:qi3) || fail "run_stats failed: $out"
python3 - "$n_cli" "$out" <<'PY' || fail "run_stats printed: $(echo "$out" | head -c 400)"
import json, sys
s = json.loads(sys.argv[2])
assert s["method"] == "bubble" and s["input"] == "case:qi3", s
assert s["nodes"] == int(sys.argv[1]) and s["valid"] is True, s
assert s["tri"]["count"] == s["triangles"] > 0 and s["distance"]["max"] > 0, s
print(f"run_stats: {s['nodes']} nodes, valid, {len(s['params'])} parameters recorded")
PY

# 4. find_package(packmesh).
cmake -S "$src/examples" -B "$work/build-examples" -DCMAKE_PREFIX_PATH="$prefix" \
  -DCMAKE_C_FLAGS="$extra" -DCMAKE_EXE_LINKER_FLAGS="$extra" >"$work/cmake.log" 2>&1 \
  || { cat "$work/cmake.log"; fail "find_package(packmesh) failed"; }
cmake --build "$work/build-examples" >"$work/build.log" 2>&1 || { cat "$work/build.log"; fail "examples do not build with CMake"; }
out=$(LD_LIBRARY_PATH="$lib" "$work/build-examples/mesh_cad" case:qi3) || fail "mesh_cad (CMake) failed"
[ "$(echo "$out" | sed -n 's/.*: \([0-9]*\) nodes.*/\1/p')" = "$n_cli" ] || fail "mesh_cad (CMake): $out"
echo "find_package(packmesh): the examples build and mesh_cad gives $n_cli nodes"

# 5. The Python module, from the installed tree only.
if [ -z "$python" ]; then
  echo "note: the build has no Python module (PM_BUILD_PYTHON off); step 5 not run"
  exit 0
fi
init=$(find "$prefix" -path '*-packages/packmesh/__init__.py' | head -1)
[ -n "$init" ] || fail "no Python package packmesh installed under $prefix"
site=$(dirname "$(dirname "$init")")
out=$(cd "$work" && env -u LD_LIBRARY_PATH -u PACKMESH_CLI PYTHONPATH="$site" PYTHONDONTWRITEBYTECODE=1 \
      "$python" - "$prefix" "$n_cli" "$work/py-study" <<'PY'
import os, sys
prefix, n_cli, study_dir = sys.argv[1], int(sys.argv[2]), sys.argv[3]
import packmesh
assert packmesh.__file__.startswith(prefix), packmesh.__file__
m = packmesh.mesh("case:qi3", method="bubble")
assert len(m.nodes) == n_cli == m.stats["nodes"], (len(m.nodes), n_cli)
# The installed extension runs on the installed library (its RPATH), not the build tree's.
with open("/proc/self/maps") as f:
    libs = {line.split()[-1] for line in f if "libpackmesh.so" in line}
assert libs and all(l.startswith(prefix) for l in libs), libs
# compare() finds the installed command from the installed module's folder.
assert packmesh.cli_path() == os.path.join(prefix, "bin", "packmesh"), packmesh.cli_path()
study = packmesh.compare({"cases": ["case:qi1"], "methods": ["bubble"],
                          "options": {"trace": False}}, study_dir)
assert [r["status"] for r in study.rows] == ["ok"], study.rows
print(f"python: packmesh {packmesh.__version__} from {os.path.dirname(packmesh.__file__)}: "
      f"{len(m.nodes)} nodes; compare through {packmesh.cli_path()}")
PY
) || fail "the installed Python module: $out"
echo "$out"
