"""compare(): a comparison study (compare/README.md) run by the packmesh command.

The comparison engine runs every row of a study as a `packmesh mesh` process of the packmesh
command, which it finds as its own executable: inside python that would be python. So compare()
writes the suite as JSON and runs `packmesh compare SUITE -o OUTDIR --quiet`; the command is the
one _paths.py names (the build tree's, or the installed bin/packmesh), or $PACKMESH_CLI.
"""
import csv
import json
import os
import subprocess
import tempfile
from collections.abc import Mapping

import numpy

from . import _paths


def cli_path():
    """The packmesh command compare() runs: $PACKMESH_CLI when set, else the command built or
    installed with this module."""
    return os.environ.get("PACKMESH_CLI") or _paths.CLI


def _value(text):
    """A results.csv field as Python: None for empty, bools, ints, floats, else the text."""
    if text == "":
        return None
    if text in ("true", "false"):
        return text == "true"
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def _column(values):
    """A column of elements.csv as a NumPy array: int64, float64, or str when not numeric."""
    for kind in (numpy.int64, numpy.float64):
        try:
            return numpy.array(values, dtype=kind)
        except ValueError:
            pass
    return numpy.array(values, dtype=str)


class Study:
    """A comparison study's folder (what `packmesh compare` writes).

    outdir        the folder
    rows          results.csv, one dict per run: case, method, seed, sweep_key, sweep_value,
                  status ("ok", "failed", "crashed", "timeout", "skipped"), error, command, row,
                  label, input, wall_s, host, then every --stats key flattened with dots
                  ("nodes", "tri.radius_ratio.median", "time_s.total"); empty fields are None,
                  numbers int or float, true/false bools
    report        the report (report.html; report.md beside it)
    results_csv, elements_csv   the paths of the two tables
    """

    def __init__(self, outdir):
        self.outdir = os.path.abspath(os.fspath(outdir))
        self.results_csv = os.path.join(self.outdir, "results.csv")
        self.elements_csv = os.path.join(self.outdir, "elements.csv")
        self.report = os.path.join(self.outdir, "report.html")
        with open(self.results_csv, newline="", encoding="utf-8") as f:
            self.rows = [{k: _value(v) for k, v in row.items()} for row in csv.DictReader(f)]

    def __repr__(self):
        ok = sum(1 for r in self.rows if r["status"] == "ok")
        return f"<packmesh.Study {self.outdir}: {len(self.rows)} runs, {ok} ok>"

    def elements(self, kind=None):
        """elements.csv as a dict of NumPy columns: row, case, method, label, seed, sweep_key,
        sweep_value, kind ("tri" or "tet"), index, cell, radius_ratio, aspect_ratio,
        min_angle_deg, max_angle_deg (one entry per element of every successful run). kind
        keeps the elements of that kind only."""
        with open(self.elements_csv, newline="", encoding="utf-8") as f:
            reader = csv.reader(f)
            header = next(reader)
            at = header.index("kind")
            rows = [r for r in reader if kind is None or r[at] == kind]
        columns = list(zip(*rows)) if rows else [()] * len(header)
        return {name: _column(list(values)) for name, values in zip(header, columns)}


def _absolute_inputs(suite):
    """The suite with its inputs that are relative file paths made absolute: a suite file's
    paths are relative to its own folder, a dict's to the current folder."""
    def fix(text):
        if text.startswith("case:") or os.path.isabs(text):
            return text
        return os.path.abspath(text)

    suite = dict(suite)
    cases = []
    for c in suite.get("cases", []):
        if isinstance(c, str):
            c = fix(c)
        elif isinstance(c, Mapping) and isinstance(c.get("input"), str):
            c = dict(c, input=fix(c["input"]))
        cases.append(c)
    if "cases" in suite:
        suite["cases"] = cases
    return suite


def compare(suite, outdir, jobs=None, timeout=None, retry_failed=False):
    """Run a comparison study into outdir and return its Study.

    suite         a dict in the suite format of compare/README.md ({"cases": [...],
                  "methods": [...], "options": {"match_nodes": true}, ...}), or the path of a
                  suite file
    outdir        the study's folder; running again into the same folder resumes (finished
                  runs are kept)
    jobs          runs at once (default: the number of cores)
    timeout       the time limit of each run in seconds (default: the suite's, else 600)
    retry_failed  rerun the runs that failed before

    A run that fails is a row with its status and message, not an exception. When the command
    itself fails (a suite it refuses: an unknown key, a missing "cases"; an unwritable outdir)
    RuntimeError carries its message, ValueError for its usage errors (exit 2: a bad jobs or
    timeout); FileNotFoundError when the command is missing (see cli_path()).
    """
    cli = cli_path()
    if not (os.path.isfile(cli) and os.access(cli, os.X_OK)):
        raise FileNotFoundError(f"the packmesh command is not at {cli} (set PACKMESH_CLI to it)")
    outdir = os.path.abspath(os.fspath(outdir))
    with tempfile.TemporaryDirectory(prefix="packmesh-suite-") as tmp:
        if isinstance(suite, Mapping):
            path = os.path.join(tmp, "suite.json")
            with open(path, "w", encoding="utf-8") as f:
                json.dump(_absolute_inputs(suite), f, indent=1)
        else:
            path = os.path.abspath(os.fspath(suite))
        cmd = [cli, "compare", path, "-o", outdir, "--quiet"]
        if jobs is not None:
            cmd += ["--jobs", str(int(jobs))]
        if timeout is not None:
            cmd += ["--timeout", str(timeout)]
        if retry_failed:
            cmd.append("--retry-failed")
        proc = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if proc.returncode != 0:
        lines = [l for l in proc.stderr.splitlines() if l.strip()]
        message = lines[-1] if lines else f"{' '.join(cmd)} exited with {proc.returncode}"
        # Exit 2 is the command's usage error: the suite (or an argument) is wrong.
        raise (ValueError if proc.returncode == 2 else RuntimeError)(message)
    return Study(outdir)
