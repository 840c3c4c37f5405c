#!/usr/bin/env bash
# The README's set-up works as written on a fresh Debian 12 machine, as root (which has no sudo)
# and as a user with sudo:
#   - every command block of "Set-up on a fresh Debian 12 machine" starts with a program of the
#     tree that is executable, and none with sudo;
#   - every folder "A short tour" names exists;
#   - scripts/install-deps.sh calls apt-get directly as root and through sudo otherwise (checked
#     with --print, which runs nothing; the other user is nobody when this runs as root).
# Usage: test_setup.sh SOURCE_DIR
set -uo pipefail
src=${1:?usage: test_setup.sh SOURCE_DIR}
readme=$src/README.md
fails=0
fail() { echo "FAIL: $*"; fails=$((fails + 1)); }

# The lines of the fenced blocks inside the section that starts with heading $1.
section_blocks() {
  awk -v head="$1" '
    /^## / { insec = (index($0, head) == 4) }
    insec && /^```/ { inblock = !inblock; next }
    insec && inblock { print }' "$readme"
}

commands=$(section_blocks "Set-up on a fresh Debian 12 machine")
[ -n "$commands" ] || fail "README has no command block under 'Set-up on a fresh Debian 12 machine'"
while IFS= read -r line; do
  [ -z "$line" ] && continue
  first=${line%% *}
  case "$first" in
    sudo) fail "README set-up command starts with sudo (root on Debian 12 has none): $line" ;;
    *) [ -x "$src/$first" ] || fail "README set-up command starts with '$first', not an executable of the tree" ;;
  esac
done <<< "$commands"

tour=$(section_blocks "A short tour" | awk '$1 ~ /\/$/ { print $1 }')
[ "$(echo "$tour" | grep -c /)" -ge 5 ] || fail "README's tour names fewer than 5 folders: $tour"
for dir in $tour; do
  [ -d "$src/$dir" ] || fail "README's tour names $dir, which is not a folder of the tree"
done

script=$src/scripts/install-deps.sh
# $1: the output of --print; $2: 1 when it must go through sudo.
check_print() {
  local out=$1 want_sudo=$2 who=$3 n=0
  while IFS= read -r line; do
    case "$line" in *apt-get*) n=$((n + 1)) ;; *) continue ;; esac
    if [ "$want_sudo" -eq 1 ]; then
      [ "${line%% *}" = sudo ] || fail "install-deps.sh as $who runs apt-get without sudo: $line"
    else
      case "$line" in *sudo*) fail "install-deps.sh as $who uses sudo: $line" ;; esac
    fi
  done <<< "$out"
  [ "$n" -eq 2 ] || fail "install-deps.sh --print as $who gave $n apt-get commands, not 2: $out"
  case "$out" in
    *"install -y"*libcgal-dev*libtet1.5-dev*libgmsh-dev*python3-meshio*python3-numpy*python3-dev*python3-pytest*) ;;
    *) fail "install-deps.sh --print as $who does not install the libraries: $out" ;; esac
}

out=$(bash "$script" --print) || fail "install-deps.sh --print failed"
if [ "$(id -u)" -eq 0 ]; then
  check_print "$out" 0 root
  if command -v setpriv >/dev/null && setpriv --reuid=65534 --regid=65534 --clear-groups test -r "$script"; then
    out=$(setpriv --reuid=65534 --regid=65534 --clear-groups bash "$script" --print) ||
      fail "install-deps.sh --print as nobody failed"
    check_print "$out" 1 nobody
  else
    echo "note: the other-user half is not checked: nobody cannot read $script or setpriv is missing"
  fi
else
  check_print "$out" 1 "uid $(id -u)"
  echo "note: the root half is not checked: this runs as uid $(id -u)"
fi
bash "$script" --nosuch 2>/dev/null
[ $? -eq 2 ] || fail "install-deps.sh with an unknown argument does not exit 2"

[ "$fails" -eq 0 ] && echo "test_setup: all checks passed"
exit $((fails > 0))
