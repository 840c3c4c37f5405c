#!/usr/bin/env python3
"""Run every ```sh block of a Markdown page, in order, as a reader following it would.

    doc_test.py PAGE.md SOURCE_DIR BUILD_DIR [--long]

The blocks run in one bash process (`set -euo pipefail`, so a failing command or check fails the
test), from a fresh folder that holds `build` and `compare` as links to BUILD_DIR and
SOURCE_DIR/compare, the layout of a checkout in which the page tells the reader to work.
BUILD_DIR is put first on PATH. A block preceded by the line `<!-- doc-test: long -->` (blank
lines between allowed) is a slow one and runs only with --long. Exit 0 when every block ran,
1 naming the block (its first line and its line in the page) that failed.
"""
import os
import re
import shutil
import subprocess
import sys
import tempfile

LONG_MARK = "<!-- doc-test: long -->"


def blocks(page):
    """[(line of the opening fence, text, long)] of the ```sh blocks."""
    out, lines, i = [], page.split("\n"), 0
    while i < len(lines):
        if lines[i].strip() == "```sh":
            start, body = i + 1, []
            j = i - 1
            while j >= 0 and not lines[j].strip():
                j -= 1
            is_long = j >= 0 and lines[j].strip() == LONG_MARK
            i += 1
            while i < len(lines) and lines[i].strip() != "```":
                body.append(lines[i])
                i += 1
            if i == len(lines):
                raise SystemExit("doc_test: a ```sh block at line %d is not closed" % start)
            out.append((start, "\n".join(body), is_long))
        i += 1
    return out


def main():
    args = [a for a in sys.argv[1:] if a != "--long"]
    run_long = "--long" in sys.argv[1:]
    if len(args) != 3:
        print(__doc__)
        return 2
    page_path, src, build = (os.path.abspath(a) for a in args)
    with open(page_path) as f:
        found = blocks(f.read())
    if not found:
        print("doc_test: %s has no ```sh block" % page_path)
        return 1
    chosen = [b for b in found if run_long or not b[2]]
    work = tempfile.mkdtemp(prefix="pm_doc_test_")
    try:
        os.symlink(build, os.path.join(work, "build"))
        os.symlink(os.path.join(src, "compare"), os.path.join(work, "compare"))
        script = ["set -euo pipefail"]
        for k, (line, text, _) in enumerate(chosen):
            # The block's number into a file of the runner's, so that a failure names it.
            script.append('echo %d >> "$PM_DOC_TEST_MARKS"' % k)
            script.append(text)
        script.append('echo done >> "$PM_DOC_TEST_MARKS"')
        marks = os.path.join(work, ".blocks")
        open(marks, "w").close()
        env = dict(os.environ, PATH=build + os.pathsep + os.environ.get("PATH", ""),
                   PM_DOC_TEST_MARKS=marks)
        p = subprocess.run(["bash", "-c", "\n".join(script)], cwd=work, env=env)
        with open(marks) as m:
            reached = m.read().split()
        if p.returncode != 0 or not reached or reached[-1] != "done":
            k = int(reached[-1]) if reached and reached[-1] != "done" else len(chosen) - 1
            line, text, _ = chosen[k]
            print("doc_test: %s: the block at line %d ('%s') failed with exit %d"
                  % (os.path.basename(page_path), line, text.split("\n")[0], p.returncode))
            return 1
        skipped = len(found) - len(chosen)
        print("doc_test: %s: %d blocks ran%s" % (os.path.basename(page_path), len(chosen),
              ", %d long ones left to --long" % skipped if skipped else ""))
        return 0
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
