#!/usr/bin/env bash
# scripts/quality_picture.py draws a mesh packmesh wrote (.vtu and .vtk) coloured by its
# per-element R / l_min, off-screen: the picture is 1200 x 900 with many colours, and the colour
# range it prints is the triangles' R / l_min range that packmesh quality measures. Skipped (exit
# 77) without python3-vtk9 or xvfb-run (scripts/install-deps.sh installs both).
# Usage: test_quality_picture.sh SOURCE_DIR PACKMESH PYTHON
set -uo pipefail
src=${1:?usage: test_quality_picture.sh SOURCE_DIR PACKMESH PYTHON}
packmesh=${2:?}
python=${3:-python3}
if ! "$python" -c "import vtk" 2>/dev/null || ! command -v xvfb-run > /dev/null; then
  echo "SKIP: needs $python with vtk (python3-vtk9) and xvfb-run (xvfb): scripts/install-deps.sh"
  exit 77
fi
dir=$(mktemp -d /tmp/pm_test_picture.XXXXXX)
trap 'rm -rf "$dir"' EXIT
fails=0
"$packmesh" mesh case:boxhole --method gmsh-frontal --volume -o "$dir/m.vtu" > /dev/null || exit 1
"$packmesh" mesh case:boxhole --method gmsh-frontal --volume -o "$dir/m.vtk" > /dev/null || exit 1
range=$("$packmesh" quality "$dir/m.vtu" --json | "$python" -c \
  'import sys, json; a = json.load(sys.stdin)["tri"]["aspect_ratio"]; print("[%.4g, %.4g]" % (a["min"], a["max"]))')
for ext in vtu vtk; do
  out=$(xvfb-run -a "$python" "$src/scripts/quality_picture.py" "$dir/m.$ext" "$dir/m_$ext.png" 2>&1) || {
    echo "FAIL: quality_picture.py m.$ext: $out"; fails=$((fails + 1)); continue; }
  echo "$out"
  case "$out" in
    *"coloured by aspect_ratio $range"*) ;;
    *) echo "FAIL: m.$ext: colour range is not the triangles' R / l_min range $range"; fails=$((fails + 1)) ;;
  esac
  colours=$("$python" - "$dir/m_$ext.png" <<'PY'
import sys, vtk
from vtk.util.numpy_support import vtk_to_numpy
r = vtk.vtkPNGReader()
r.SetFileName(sys.argv[1])
r.Update()
img = r.GetOutput()
w, h, _ = img.GetDimensions()
px = vtk_to_numpy(img.GetPointData().GetScalars())
print(w, h, len({tuple(p[:3]) for p in px}))
PY
)
  read -r w h n <<< "$colours"
  if [ "$w" != 1200 ] || [ "$h" != 900 ] || [ "${n:-0}" -lt 100 ]; then
    echo "FAIL: m_$ext.png is ${w}x${h} with ${n} colours (1200x900 and 100 or more expected)"
    fails=$((fails + 1))
  else
    echo "m_$ext.png: ${w}x${h}, $n colours"
  fi
done
# Bad input: one line, exit 1.
err=$("$python" "$src/scripts/quality_picture.py" "$dir/m.msh" "$dir/x.png" 2>&1)
rc=$?
if [ $rc -ne 1 ] || [ "$(echo "$err" | wc -l)" -ne 1 ] || [ -e "$dir/x.png" ]; then
  echo "FAIL: a .msh: exit $rc, '$err'"; fails=$((fails + 1))
fi
exit $((fails > 0))
