#!/bin/bash
# packmesh animate: bubble's frames of qi3 become a GIF with one image per SVG frame (read back
# by tests/scripts/gif_info.py) and an HTML player that headless Chromium loads without a console
# error, whose slider and play button move the frames (tests/scripts/page_check.py). The frames
# show the triangulation, the phase and the step; psys's are coloured by energy and drawn at
# edge_per_sigma sigma / 2. Bad input: one line, exit 2 (usage) or 1, nothing left behind.
#
# usage: test_cli_animate.sh SOURCE_DIR PACKMESH PYTHON
set -u
src=$1 pm=$2 py=$3
tmp=$(mktemp -d /tmp/pm_animate_XXXXXX)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*"; exit 1; }

# bubble on qi3 (its own field, 712 nodes in the paper), a frame every 10 steps
"$pm" mesh case:qi3 --method bubble -o "$tmp/b.msh" --frames "$tmp/bf" --quiet \
  || fail "mesh --frames exited $?"
nsvg=$(ls "$tmp/bf" | grep -c '^frame_[0-9]\{6\}\.svg$')
ndat=$(ls "$tmp/bf" | grep -c '^frame_[0-9]\{6\}\.dat$')
[ "$nsvg" -ge 5 ] && [ "$nsvg" = "$ndat" ] || fail "$nsvg SVG and $ndat .dat frames"
last=$(ls "$tmp/bf"/frame_*.svg | tail -1)
grep -q 'phase 2 (surface): step' "$last" || fail "the last frame names no phase and step"
grep -q '<path fill="none" stroke="#b0b0b0"' "$last" || fail "the last frame has no triangulation"
grep -q 'viewBox=' "$last" || fail "the frames have no viewBox"

out=$("$pm" animate "$tmp/bf" -o "$tmp/anim/qi3" --delay 80 2>&1) && fail "animate into a missing folder succeeded"
mkdir "$tmp/anim"
out=$("$pm" animate "$tmp/bf" -o "$tmp/anim/qi3" --delay 80 2>&1) || fail "animate exited $?: $out"
echo "$out" | grep -q "^$nsvg frames -> " || fail "animate said: $out"
info=$("$py" "$src/tests/scripts/gif_info.py" "$tmp/anim/qi3.gif") || fail "$info"
echo "$info"
frames=$(echo "$info" | sed -n 's/^frames \([0-9]*\) .*/\1/p')
[ "$frames" = "$nsvg" ] || fail "the GIF has $frames images, the folder $nsvg frames"
echo "$info" | grep -q "delays 8,8," || fail "the GIF's delays are not 8 cs: $info"
[ "$(ls "$tmp/anim")" = "$(printf 'qi3.gif\nqi3.html')" ] || fail "left in the output folder: $(ls "$tmp/anim")"
[ "$(grep -c '<svg' "$tmp/anim/qi3.html")" = "$nsvg" ] || fail "the player does not hold every frame"
grep -q '<script src\|<link ' "$tmp/anim/qi3.html" && fail "the player loads another file"

# The player in headless Chromium: no console error; the slider shows the frame it is set to;
# play advances the frames, pause stops them.
js_slider="(function(){var s=document.getElementById('slider');s.value=3;s.dispatchEvent(new Event('input'));var on=document.querySelectorAll('.frame.on');return on.length==1&&on[0].id=='f3'&&document.getElementById('label').textContent=='frame 4 of $nsvg';})()"
js_play="new Promise(function(ok){var b=document.getElementById('play');b.click();setTimeout(function(){var f=document.querySelector('.frame.on').id;b.click();var g=document.querySelector('.frame.on').id;setTimeout(function(){ok(f!='f3'&&b.textContent=='play'&&document.querySelector('.frame.on').id==g);},300);},400);})"
js_first="document.getElementById('label').textContent=='frame 1 of $nsvg'&&document.querySelector('.frame.on').id=='f0'"
"$py" "$src/tests/scripts/page_check.py" "$tmp/anim/qi3.html" --expect-text "of $nsvg" \
  --eval "$js_first" --eval "$js_slider" --eval "$js_play" --screenshot "$tmp/player.png"
rc=$?
[ $rc = 77 ] && { echo "skipped: chromium is not installed"; exit 77; }
[ $rc = 0 ] || fail "page_check exited $rc"
[ -n "${PM_SHOTS:-}" ] && cp "$tmp/player.png" "$PM_SHOTS/animate_player.png" && cp "$tmp/anim/qi3.gif" "$PM_SHOTS/animate_qi3.gif" && cp "$last" "$PM_SHOTS/frame_qi3_bubble_last.svg"

# psys: coloured by energy, circles at edge_per_sigma sigma / 2 (0.33 sigma with the defaults)
"$pm" mesh case:qi3 --method psys --size 0.4 -o "$tmp/p.msh" --frames "$tmp/pf" --quiet \
  || fail "psys mesh --frames exited $?"
plast=$(ls "$tmp/pf"/frame_*.svg | tail -1)
grep -q 'phase 3 (faces): step .*, coloured by energy' "$plast" || fail "psys's last frame: no phase or energy"
grep -q 'fill-opacity' "$plast" || fail "psys's particles are not filled by energy"
vtu=${plast%.svg}.vtu
grep -q 'Name="energy"' "$vtu" || fail "psys's .vtu has no energy"
"$py" - "$plast" "$vtu" <<'EOF' || fail "psys's circles are not 0.33 sigma"
import re, sys
svg, vtu = open(sys.argv[1]).read(), open(sys.argv[2]).read()
w = float(re.search(r'viewBox="0 0 ([0-9.]+)', svg).group(1))
r_svg = [float(x) for x in re.findall(r'<circle [^>]*r="([0-9.]+)"', svg)]
radius = vtu.split('Name="radius" format="ascii">')[1].split("</DataArray>")[0].split()
sigma = [float(x) for x in radius]
# the picture is 800 px across the box and 3% padding on each side: 6 x 6 box, scale 800 / 6.36
scale = 800 / (6 * 1.06)
bad = [i for i, (a, s) in enumerate(zip(r_svg, sigma)) if abs(a - 0.33 * s * scale) > 0.011]
print("psys circles: %d, off: %d" % (len(r_svg), len(bad)))
sys.exit(1 if bad or len(r_svg) != len(sigma) else 0)
EOF
"$pm" animate "$tmp/pf" -o "$tmp/anim/psys" >/dev/null || fail "animate of psys's frames"

# Bad input: one line each, the exit code, nothing written.
check() { # expected-exit pattern args...
  local want=$1 pat=$2
  shift 2
  local err rc
  err=$("$pm" animate "$@" 2>&1 >/dev/null)
  rc=$?
  [ $rc = "$want" ] || fail "animate $*: exit $rc, not $want ($err)"
  [ "$(echo "$err" | wc -l)" = 1 ] || fail "animate $*: not one line: $err"
  echo "$err" | grep -q "$pat" || fail "animate $*: '$err' does not say '$pat'"
}
mkdir "$tmp/empty" "$tmp/bad"
check 2 "no frames folder" -o "$tmp/bad/x"
check 2 "no output" "$tmp/bf"
check 2 "delay" "$tmp/bf" -o "$tmp/bad/x" --delay 0
check 2 "unknown option" "$tmp/bf" -o "$tmp/bad/x" --fps 3
check 1 "cannot read the frames folder" "$tmp/nowhere" -o "$tmp/bad/x"
check 1 "holds no frame_NNNNNN.svg" "$tmp/empty" -o "$tmp/bad/x"
cp "$tmp/bf/frame_000000.svg" "$tmp/empty/"
check 1 "frame_000000.dat' is missing" "$tmp/empty" -o "$tmp/bad/x"
[ -z "$(ls "$tmp/bad")" ] || fail "bad input left $(ls "$tmp/bad")"
[ -z "$(ls "$tmp/empty" | grep -v '^frame_000000.svg$')" ] || fail "left in the frames folder"
echo "ok: $nsvg frames"
