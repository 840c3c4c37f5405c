#!/usr/bin/env bash
# The files packmesh writes are read by meshio (Debian's python3-meshio, which
# scripts/install-deps.sh installs): a solid with segments, triangles and tets written as .msh
# (the default: no parametric nodes, which meshio 7 refuses) as .vtu and as legacy .vtk, read back by meshio with
# the node and element counts packmesh printed, and the per-element quality (.vtu and .vtk cell
# data, .msh $ElementData) with the median R / l_min packmesh quality gives; .vtu and .vtk also
# carry each element's model cell (cell data "cell"), on every triangle. Without python3-meshio the test
# is reported as skipped (exit 77), never passed.
# Usage: test_mesh_meshio.sh PACKMESH PYTHON
set -uo pipefail
packmesh=${1:?usage: test_mesh_meshio.sh PACKMESH PYTHON}
python=${2:-python3}
if ! "$python" -c "import meshio, numpy" 2>/dev/null; then
  echo "SKIP: $python cannot import meshio and numpy (install python3-meshio python3-numpy: scripts/install-deps.sh)"
  exit 77
fi
dir=$(mktemp -d /tmp/pm_test_meshio.XXXXXX)
trap 'rm -rf "$dir"' EXIT
fails=0
for ext in msh vtu vtk; do
  line=$("$packmesh" mesh case:boxhole --method bubble --volume -o "$dir/m.$ext") || {
    echo "FAIL: packmesh mesh -o m.$ext failed"; fails=$((fails + 1)); continue; }
  # "bubble case:boxhole: N nodes, S segments, T triangles, K tets in ..."
  read -r nodes segs tris tets <<< "$(echo "$line" | sed -E 's/.*: ([0-9]+) nodes, ([0-9]+) segments, ([0-9]+) triangles, ([0-9]+) tets.*/\1 \2 \3 \4/')"
  got=$("$python" - "$dir/m.$ext" <<'PY'
import sys, meshio
m = meshio.read(sys.argv[1])
count = {"line": 0, "triangle": 0, "tetra": 0}
for block in m.cells:
    if block.type in count:
        count[block.type] += len(block.data)
print("counts", len(m.points), count["line"], count["triangle"], count["tetra"])
# per-element quality for colouring (.vtu cell data, .msh $ElementData): R / l_min of the
# triangles, as packmesh measures it
import numpy
rl = numpy.concatenate([a for b, a in zip(m.cells, m.cell_data["aspect_ratio"])
                        if b.type == "triangle"])
print("tri_aspect_median %.9f" % numpy.median(rl))
if not sys.argv[1].endswith(".msh"):
    tags = numpy.concatenate([a for b, a in zip(m.cells, m.cell_data["cell"])
                              if b.type == "triangle"])
    print("tri_untagged", int((tags < 0).sum()))
PY
) || { echo "FAIL: meshio cannot read m.$ext"; fails=$((fails + 1)); continue; }
  # meshio may print notes of its own before the line of counts
  raw=$got
  got=$(echo "$raw" | sed -n 's/^counts //p')
  if [ "$got" != "$nodes $segs $tris $tets" ]; then
    echo "FAIL: m.$ext: meshio reads points/lines/triangles/tets $got, packmesh wrote $nodes $segs $tris $tets"
    fails=$((fails + 1))
  else
    echo "m.$ext: meshio reads $got (points, lines, triangles, tets), as written"
  fi
  [ "$tets" -gt 0 ] || { echo "FAIL: no tets in m.$ext"; fails=$((fails + 1)); }
  # the cell data's median R / l_min equals packmesh quality's (the median of the triangles)
  want=$("$packmesh" quality "$dir/m.$ext" --json | "$python" -c \
    'import sys, json; print("%.9f" % json.load(sys.stdin)["tri"]["aspect_ratio"]["median"])')
  med=$(echo "$raw" | sed -n 's/^tri_aspect_median //p')
  if [ -z "$med" ] || [ "$med" != "$want" ]; then
    echo "FAIL: m.$ext: cell data aspect_ratio median '$med', packmesh quality $want"
    fails=$((fails + 1))
  else
    echo "m.$ext: cell data aspect_ratio (R/l_min) median $med, as packmesh quality measures"
  fi
  if [ "$ext" != msh ]; then
    untagged=$(echo "$raw" | sed -n 's/^tri_untagged //p')
    if [ "$untagged" != 0 ]; then
      echo "FAIL: m.$ext: cell data 'cell' has '$untagged' untagged triangles"
      fails=$((fails + 1))
    else
      echo "m.$ext: cell data 'cell' gives every triangle its face"
    fi
  fi
done
exit $((fails > 0))
