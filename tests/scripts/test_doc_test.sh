#!/bin/bash
# tests/scripts/doc_test.py on small pages: blocks run in order in one shell (a variable set in
# one is seen by the next), a failing block fails the test and is named by its line, a block
# marked long runs only with --long, and the page's folder layout (build, compare) is there.
#
# usage: test_doc_test.sh SOURCE_DIR BUILD_DIR PYTHON
set -u
src=$1 build=$2 py=$3
tmp=$(mktemp -d /tmp/pm_doc_test_XXXXXX)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
run() { "$py" "$src/tests/scripts/doc_test.py" "$1" "$src" "$build" ${2:-}; }

printf '# ok\n\n```sh\nx=3\ntest -x build/packmesh && test -f compare/suites/qi.json\n```\n\n```sh\ntest "$x" = 3\n```\n\n<!-- doc-test: long -->\n\n```sh\nfalse\n```\n' > "$tmp/a.md"
out=$(run "$tmp/a.md") || fail "a good page failed: $out"
echo "$out" | grep -q "2 blocks ran, 1 long ones left to --long" || fail "$out"
out=$(run "$tmp/a.md" --long) && fail "the long block did not run: $out"
echo "$out" | grep -q "the block at line 14 ('false') failed" || fail "$out"
printf '```sh\necho one\n```\n\n```sh\nls no-such-file\necho never\n```\n' > "$tmp/b.md"
out=$(run "$tmp/b.md" 2>&1) && fail "a failing block passed: $out"
echo "$out" | grep -q "line 5 ('ls no-such-file') failed" || fail "$out"
echo "$out" | grep -q never && fail "the script went on after a failure"
echo ok
