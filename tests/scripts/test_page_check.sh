#!/usr/bin/env bash
# tests/scripts/page_check.py, the headless-Chromium check the report and player tests use: a
# drawn WebGL canvas passes, a screenshot of the page or of one element has its size, and a blank
# canvas, a console error and a missing script each fail with a line naming what went wrong. Skipped (77) without chromium or three.js.
set -uo pipefail
src=$1
python=${2:-/usr/bin/python3}
check="$python $src/tests/scripts/page_check.py"
pages=$src/tests/data/pages
command -v chromium >/dev/null || { echo "skipped: chromium is not installed"; exit 77; }
[ -f /usr/share/javascript/three/three.min.js ] || { echo "skipped: libjs-three is not installed"; exit 77; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail=0

out=$($check "$pages/drawn.html" --canvas '#view' --screenshot "$work/shot.png" \
      --eval "document.getElementById('view').click() || true" --expect-text clicked 2>&1)
rc=$?
[ $rc -eq 0 ] || { echo "drawn.html: exit $rc, expected 0: $out"; fail=1; }
# A PNG of the whole 1200x900 view.
head -c 24 "$work/shot.png" | od -An -tx1 | tr -d ' \n' | grep -q '^89504e470d0a1a0a0000000d49484452000004b000000384$' \
  || { echo "the screenshot is not a 1200x900 PNG"; fail=1; }

# --screenshot-of: the element's box only (the 300x200 canvas), wherever it is.
out=$($check "$pages/drawn.html" --screenshot "$work/canvas.png" --screenshot-of '#view' 2>&1)
rc=$?
[ $rc -eq 0 ] || { echo "--screenshot-of: exit $rc, expected 0: $out"; fail=1; }
head -c 24 "$work/canvas.png" | od -An -tx1 | tr -d ' \n' | grep -q '^89504e470d0a1a0a0000000d494844520000012c000000c8$' \
  || { echo "the element's screenshot is not a 300x200 PNG"; fail=1; }
out=$($check "$pages/drawn.html" --screenshot "$work/none.png" --screenshot-of '#no_such' 2>&1)
[ $? -eq 1 ] && grep -q "no visible element '#no_such' to take a screenshot of" <<<"$out" && [ ! -e "$work/none.png" ] \
  || { echo "--screenshot-of a missing element: not reported, or a file written: $out"; fail=1; }

expect_fail() {  # PAGE EXPECTED-TEXT
  local out rc
  out=$($check "$pages/$1" --canvas '#view' 2>&1)
  rc=$?
  [ $rc -eq 1 ] || { echo "$1: exit $rc, expected 1: $out"; fail=1; }
  grep -q -- "$2" <<<"$out" || { echo "$1: no line with '$2' in: $out"; fail=1; }
}
expect_fail blank.html "'#view' is blank"
expect_fail console_error.html "console error: drawn, then failed"
expect_fail missing_script.html "no_such_file.js"
expect_fail missing_script.html "THREE is not defined"
# --expect-text and --eval failures name what was asked.
out=$($check "$pages/drawn.html" --expect-text "no such words" --eval "1 == 2" 2>&1)
[ $? -eq 1 ] && grep -q "has no 'no such words'" <<<"$out" && grep -q -- "--eval 1 == 2: gave False" <<<"$out" \
  || { echo "expect-text/eval failures not reported: $out"; fail=1; }

[ $fail -eq 0 ] && echo "page_check: 8 pages checked"
exit $fail
