#!/usr/bin/env python3
"""The man pages the build made (build/man/man1) say what --help says, and render cleanly:

  - there is a page for packmesh and for every command `packmesh --help` lists, and the build's
    list (PM_CLI_PAGES) names the same commands;
  - each page is what `packmesh help --man` prints now (the build made it from this binary);
  - every option a command's --help names is in its page (as roff writes it: \\-\\-size), and
    every option line of --help is an option (.TP) of the page;
  - every parameter key of every method (`packmesh mesh --method M --help`) is an entry of
    packmesh-mesh(1) under its method, every built-in case one of packmesh-cases(1), every
    reference one of packmesh-references(1); packmesh(1) has each command, the exit codes
    0/1/2/130/143, ENVIRONMENT and FILES;
  - `groff -ww -z -man` reads each page with no warning, and the page rendered as text shows
    the options as typed (--target-nodes).
Without groff the other checks run and the test is reported as skipped (exit 77), never passed.

Usage: test_cli_man.py PACKMESH MAN_DIR PAGE...   (PAGE: the commands the build made pages for)
"""
import os
import re
import shutil
import subprocess
import sys

packmesh, man_dir, built = sys.argv[1], sys.argv[2], sys.argv[3:]
failures = []


def fail(msg):
    failures.append(msg)
    print("FAIL: " + msg)


def run(*args):
    p = subprocess.run([packmesh, *args], capture_output=True, text=True)
    if p.returncode != 0 or p.stderr:
        fail(f"packmesh {' '.join(args)}: exit {p.returncode}: {p.stderr.strip()}")
    return p.stdout


def roff(text):
    """text as the pages write it: backslashes as \\e, hyphens as \\-."""
    return text.replace("\\", "\\e").replace("-", "\\-")


def page_of(command):
    name = "packmesh" + (f"-{command}" if command else "")
    path = os.path.join(man_dir, name + ".1")
    if not os.path.isfile(path):
        fail(f"{name}.1 is not in {man_dir}")
        return name, ""
    with open(path, encoding="utf-8") as f:
        return name, f.read()


# Options a help text names: "--size", "-o" at the start of a word (not "built-in", "t-1").
OPTION = re.compile(r"(?<![\w\-])(--?[A-Za-z][\w\-]*)")


def option_lines(help_text):
    """The names of the options --help lists one per line ("  -o, --output DIR  ...")."""
    names = []
    for line in help_text.splitlines():
        # Indented by 2 to 4: deeper lines continue an option's text, even when they start
        # with an option's name.
        m = re.match(r" {2,4}(-\S.*?)(?: {2,}|$)", line)
        if m:
            names += [w.rstrip(",") for w in m.group(1).split() if w.startswith("-")]
    return names


# The commands: `packmesh --help`'s list against the build's.
top = run("--help")
block = top.split("\ncommands:\n", 1)[1].split("\n\n", 1)[0] if "\ncommands:\n" in top else ""
commands = [line.split()[0] for line in block.splitlines() if line.strip()]
if len(commands) < 6:
    fail(f"packmesh --help lists {len(commands)} commands: {commands}")
if sorted(commands) != sorted(built):
    fail(f"the build makes pages for {built}, packmesh --help lists {commands} (PM_CLI_PAGES)")

pages = {}
for command in [None] + commands:
    name, text = page_of(command)
    pages[command] = text
    fresh = run("help", "--man", *([command] if command else []))
    if text and text != fresh:
        fail(f"{name}.1 differs from what 'packmesh help --man {command or ''}' prints now")

# packmesh(1): the commands and the top level's tables.
top_page = pages[None]
for command in commands:
    if f".TP\n\\fB{roff(command)}\\fR\n" not in top_page:
        fail(f"packmesh.1 has no entry for the command {command}")
for section in ("SYNOPSIS", "DESCRIPTION", "COMMANDS", "EXIT STATUS", "ENVIRONMENT", "FILES",
                "SEE ALSO"):
    if f"\n.SH {section}\n" not in top_page:
        fail(f"packmesh.1 has no section {section}")
for code in ("0", "1", "2", "130", "143"):
    if f".TP\n\\fB{code}\\fR\n" not in top_page:
        fail(f"packmesh.1 does not explain exit code {code}")
for option in OPTION.findall(top):
    if roff(option) not in top_page:
        fail(f"packmesh --help names {option}, packmesh.1 does not")

# Each command's options.
noptions = 0
for command in commands:
    help_text = run(command, "--help")
    page = pages[command]
    for option in sorted(set(OPTION.findall(help_text))):
        noptions += 1
        if roff(option) not in page:
            fail(f"packmesh {command} --help names {option}, packmesh-{command}.1 does not")
    listed = option_lines(help_text)
    if not listed:
        fail(f"packmesh {command} --help has no option lines")
    lines = page.splitlines()
    tags = [lines[i + 1] for i in range(len(lines) - 1) if lines[i] == ".TP"]
    for option in listed:
        if not any(f"\\fB{roff(option)}\\fR" in tag for tag in tags):
            fail(f"packmesh-{command}.1 has no option entry (.TP) for {option}")

# Every method's parameters in packmesh-mesh(1), each under its method.
mesh_page = pages.get("mesh", "")
methods_line = re.search(r"^methods: (.*?) \(default", run("mesh", "--help"), re.M)
methods = methods_line.group(1).split(", ") if methods_line else []
if len(methods) < 6:
    fail(f"mesh --help lists {len(methods)} methods: {methods}")
nkeys = 0
sections = re.split(r"^\.SS ", mesh_page, flags=re.M)
by_method = {s.split("\n", 1)[0]: s for s in sections[1:]}
for method in methods:
    rows = run("mesh", "--method", method, "--help").splitlines()
    keys = []
    if any(r.lstrip().startswith("KEY ") for r in rows):
        start = next(i for i, r in enumerate(rows) if r.lstrip().startswith("KEY "))
        keys = [r.split()[0] for r in rows[start + 1:] if r.startswith("  ")]
    section = by_method.get(roff(method))
    if section is None:
        fail(f"packmesh-mesh.1 has no METHOD PARAMETERS subsection for {method}")
        continue
    for key in keys:
        nkeys += 1
        if f".TP\n\\fB{roff(key)}\\fR\n" not in section:
            fail(f"packmesh-mesh.1 lacks parameter {key} of {method}")
if nkeys < 50:
    fail(f"only {nkeys} parameter keys found in the methods' --help")

# The built-in cases and the references.
cases = [line.split()[0] for line in run("cases").splitlines()[1:] if line.strip()]
for case in cases:
    if f".TP\n\\fBcase:{roff(case)}\\fR\n" not in pages.get("cases", ""):
        fail(f"packmesh-cases.1 lacks case:{case}")
refs = re.findall(r"^papers/(\d+)  ", run("references"), re.M)
for key in refs:
    if f".TP\n\\fBpapers/{key}\\fR\n" not in pages.get("references", ""):
        fail(f"packmesh-references.1 lacks papers/{key}")
if len(cases) < 5 or len(refs) < 4:
    fail(f"cases {cases}, references {refs}: fewer than expected")

# Rendering.
skipped = False
if shutil.which("groff") is None:
    print("SKIP: groff is not installed (groff-base: scripts/install-deps.sh); pages not rendered")
    skipped = True
else:
    for command, text in pages.items():
        name = "packmesh" + (f"-{command}" if command else "")
        p = subprocess.run(["groff", "-ww", "-z", "-man"], input=text, capture_output=True,
                           text=True)
        if p.returncode != 0 or p.stdout or p.stderr:
            fail(f"groff -ww -z -man {name}.1: exit {p.returncode}: {(p.stderr + p.stdout).strip()}")
    # As text, wide enough that no option is broken across lines: the options as typed.
    p = subprocess.run(["groff", "-man", "-Tascii", "-rLL=300n"], input=mesh_page,
                       capture_output=True, text=True)
    shown = re.sub(r".\x08", "", p.stdout)
    for option in sorted(set(OPTION.findall(run("mesh", "--help")))):
        if option not in shown:
            fail(f"packmesh-mesh.1 rendered by groff does not show {option}")

if failures:
    print(f"test_cli_man: {len(failures)} failures")
    sys.exit(1)
print(f"test_cli_man: {len(pages)} pages, {noptions} options of {len(commands)} commands, "
      f"{nkeys} parameters of {len(methods)} methods, {len(cases)} cases, {len(refs)} references")
sys.exit(77 if skipped else 0)
