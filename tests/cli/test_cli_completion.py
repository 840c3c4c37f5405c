#!/usr/bin/env python3
"""The bash completion the build made (build/completion/packmesh) completes what --help lists.

The script is sourced in `bash -c`, COMP_WORDS and COMP_CWORD are set as bash sets them (which
splits words at ':' and '=') and _packmesh is called; its COMPREPLY is compared with what the
command itself prints:
  - the script is what `packmesh help --bash-completion` prints now, and bash reads it;
  - `packmesh me` completes to mesh, an empty first word to every command of `packmesh --help`;
  - `packmesh mesh --method ` to the methods of `packmesh mesh --help`, `--method=g` to the gmsh
    ones;
  - `--set k` after `--method bubble` to k0= (the only bubble key starting with k), `--set s_`
    after `--method psys` to psys's keys starting with s_, `--set integrator=r` to rk4 and rk2;
  - `packmesh mesh case:q` to case:qi1..qi4 (and, split at ':', to qi1..qi4);
  - `packmesh COMMAND -` to every option of COMMAND's --help option lines and synopsis;
  - files by extension: -o a mesh file or a folder, INPUT a CAD or case file, a folder or
    case:, quality's MESH a mesh file, --frames a folder only.

Usage: test_cli_completion.py PACKMESH COMPLETION_FILE
"""
import os
import re
import subprocess
import sys
import tempfile

packmesh, script = sys.argv[1], sys.argv[2]
failures = []


def fail(msg):
    failures.append(msg)
    print("FAIL: " + msg)


def run(*args):
    p = subprocess.run([packmesh, *args], capture_output=True, text=True)
    if p.returncode != 0:
        fail(f"packmesh {' '.join(args)}: exit {p.returncode}: {p.stderr.strip()}")
    return p.stdout


def complete(words, cwd=None):
    """COMPREPLY for the command line `words` (the last is the word under the cursor)."""
    quoted = " ".join("'" + w.replace("'", "'\\''") + "'" for w in words)
    program = (f'source "$1" || exit 3\nCOMP_WORDS=({quoted})\n'
               'COMP_CWORD=$((${#COMP_WORDS[@]} - 1))\n_packmesh\n'
               'printf "%s\\n" "${COMPREPLY[@]}"')
    p = subprocess.run(["bash", "--norc", "-c", program, "bash", os.path.abspath(script)],
                       capture_output=True, text=True, cwd=cwd)
    if p.returncode != 0 or p.stderr:
        fail(f"completing {words}: exit {p.returncode}: {p.stderr.strip()}")
    return [line for line in p.stdout.split("\n") if line]


def expect(words, want, cwd=None):
    got = complete(words, cwd)
    if sorted(got) != sorted(want):
        fail(f"{' '.join(words)!r} completes to {got}, not {sorted(want)}")


with open(script, encoding="utf-8") as f:
    text = f.read()
if text != run("help", "--bash-completion"):
    fail(f"{script} differs from what 'packmesh help --bash-completion' prints now")
p = subprocess.run(["bash", "-n", script], capture_output=True, text=True)
if p.returncode != 0:
    fail(f"bash -n {script}: {p.stderr.strip()}")

# Commands.
top = run("--help")
block = top.split("\ncommands:\n", 1)[1].split("\n\n", 1)[0]
commands = [line.split()[0] for line in block.splitlines() if line.strip()]
expect(["packmesh", "me"], ["mesh"])
expect(["packmesh", ""], commands + ["--help", "--version"])

# Methods and their parameters.
mesh_help = run("mesh", "--help")
methods = re.search(r"^methods: (.*?) \(default", mesh_help, re.M).group(1).split(", ")
expect(["packmesh", "mesh", "--method", ""], methods)
expect(["packmesh", "mesh", "case", ":", "qi3", "--method", "=", "g"],
       [m for m in methods if m.startswith("g")])


def keys(method):
    rows = run("mesh", "--method", method, "--help").splitlines()
    start = next(i for i, r in enumerate(rows) if r.lstrip().startswith("KEY "))
    return [r.split()[0] for r in rows[start + 1:] if r.startswith("  ")]


expect(["packmesh", "mesh", "case", ":", "qi3", "--method", "bubble", "--set", "k"],
       [k + "=" for k in keys("bubble") if k.startswith("k")])
if "k0" not in keys("bubble"):
    fail("bubble has no parameter k0")
expect(["packmesh", "mesh", "case:qi3", "--method", "psys", "--set", "s_"],
       [k + "=" for k in keys("psys") if k.startswith("s_")])
expect(["packmesh", "mesh", "case:qi3", "--set", "integrator", "=", "r"], ["rk4", "rk2"])

# Built-in cases, as one word and split at ':' as bash splits it.
qi = [line.split()[0] for line in run("cases").splitlines()[1:] if line.startswith("q")]
if len(qi) != 4:
    fail(f"packmesh cases lists {qi} as the qi cases")
expect(["packmesh", "mesh", "case:q"], ["case:" + c for c in qi])
expect(["packmesh", "mesh", "case", ":", "q"], qi)

# Every option of every command.
for command in commands:
    help_text = run(command, "--help")
    synopsis = help_text.split("\n\n", 1)[0].split("\n")
    synopsis = [synopsis[0]] + [line for line in synopsis[1:] if line.startswith(" ")]
    listed = set(re.findall(r"(?<![\w\-])(--?[A-Za-z][\w\-]*)", " ".join(synopsis)))
    for line in help_text.splitlines():
        m = re.match(r" {2,4}(-\S.*?)(?: {2,}|$)", line)
        if m:
            listed |= {w.rstrip(",") for w in m.group(1).split() if w.startswith("-")}
    if len(listed) < 2:
        fail(f"packmesh {command} --help lists options {listed}")
    got = complete(["packmesh", command, "-"])
    missing = listed - set(got)
    if missing:
        fail(f"'packmesh {command} -' does not complete {sorted(missing)}")

# Files by extension.
with tempfile.TemporaryDirectory(prefix="pm_test_completion.") as d:
    for name in ("a.msh", "b.step", "c.txt", "d.json", "E.STP"):
        open(os.path.join(d, name), "w").close()
    os.mkdir(os.path.join(d, "sub"))
    expect(["packmesh", "mesh", "case:qi3", "-o", ""], ["a.msh", "sub"], d)
    expect(["packmesh", "mesh", ""], ["case:", "b.step", "d.json", "E.STP", "sub"], d)
    expect(["packmesh", "mesh", "c"], ["case:"], d)
    expect(["packmesh", "quality", ""], ["a.msh", "sub"], d)
    expect(["packmesh", "mesh", "case:qi3", "--frames", ""], ["sub"], d)
    expect(["packmesh", "mesh", "case:qi3", "--stats", ""], ["d.json", "sub"], d)
    expect(["packmesh", "help", "--man", ""], commands, d)

if failures:
    print(f"test_cli_completion: {len(failures)} failures")
    sys.exit(1)
print(f"test_cli_completion: {len(commands)} commands, {len(methods)} methods, options and files "
      "complete as --help lists them")
