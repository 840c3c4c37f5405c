#!/usr/bin/env python3
"""The convergence figures of a study and the traces they read (plot_convergence.c).

Usage: test_compare_convergence.py PACKMESH

A study of qi3 (bubble and psys, two seeds each, a coarse field) and of boxhole with tets (bubble,
one seed): every trace has the `nodes` and `event` columns, one row per step / iteration
(event 0) as many as the stats' iterations, a row per population control (event 1) whose node
count is the step's plus its insertions less its deletions, and a last row (event 3) whose node
count is the mesh's -- in bubble's volume phase too, where `bubbles` counts volume bubbles only.
The figure convergence_qi3 has one panel per measure in one column per method, every seed and
their mean, psys's phase boundary labelled; its files exist and the SVG draws what the script
says.
"""
import csv
import json
import os
import shutil
import subprocess
import sys
import tempfile


def fail(msg):
    print("FAIL:", msg)
    sys.exit(1)


def read_trace(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    head = rows[0]
    out = []
    for r in rows[1:]:
        out.append({k: (float(v) if v != "" else None) for k, v in zip(head, r)})
    return head, out


def check_trace(run, head, rows, stats, method):
    for col in ("nodes", "event"):
        if col not in head:
            fail(f"{run}: trace columns {head} lack {col}")
    steps = [r for r in rows if r["event"] == 0]
    if len(steps) != stats["iterations"]:
        fail(f"{run}: {len(steps)} step rows, stats iterations {stats['iterations']}")
    last = rows[-1]
    if last["event"] != 3 or last["nodes"] != stats["nodes"]:
        fail(f"{run}: last row event {last['event']} nodes {last['nodes']}, mesh {stats['nodes']}")
    if sum(r["event"] == 3 for r in rows) != 1:
        fail(f"{run}: more than one mesh row")
    controls = 0
    prev = None
    for r in rows:
        if r["event"] == 1:
            controls += 1
            want = prev["nodes"] + r["insertions"] - r["deletions"]
            if r["nodes"] != want:
                fail(f"{run}: control row at step {r['step']}: nodes {r['nodes']}, want {want}")
            if r["kinetic"] is not None:
                fail(f"{run}: a control row carries step measures")
        prev = r
    if method == "bubble" and controls == 0:
        fail(f"{run}: bubble's trace has no population control row")
    return controls


def main():
    packmesh = sys.argv[1]
    tmp = tempfile.mkdtemp(prefix="pm_conv_")
    try:
        suite = {
            "name": "convergence",
            "cases": [
                {"input": "case:qi3", "size": "0.4*abs(r-2)+0.3"},
                {"input": "case:boxhole", "size": 0.3, "volume": True},
            ],
            "methods": ["bubble", {"method": "psys", "cases": ["qi3"]}],
            "seeds": [1, 2],
            "options": {"threads": 1, "timeout_s": 240},
        }
        sp = os.path.join(tmp, "suite.json")
        with open(sp, "w") as f:
            json.dump(suite, f)
        out = os.path.join(tmp, "study")
        p = subprocess.run([packmesh, "compare", sp, "-o", out, "--jobs", "2"],
                           capture_output=True, text=True)
        if p.returncode != 0:
            fail(f"compare exited {p.returncode}: {p.stderr}")
        runs = sorted(os.listdir(os.path.join(out, "runs")))
        if len(runs) != 6:
            fail(f"{len(runs)} runs: {runs}")
        for run in runs:
            d = os.path.join(out, "runs", run)
            with open(os.path.join(d, "stats.json")) as f:
                stats = json.load(f)
            head, rows = read_trace(os.path.join(d, "trace.csv"))
            check_trace(run, head, rows, stats, stats["method"])
            if "boxhole" in run:
                vol = [r for r in rows if r["event"] == 0 and r["phase"] == 3]
                if not vol:
                    fail(f"{run}: no volume phase in the trace")
                # the relaxation counts volume bubbles; the node count counts them all
                if not all(r["nodes"] > r["bubbles"] for r in vol):
                    fail(f"{run}: nodes do not include the surface in the volume phase")
        plots = os.path.join(out, "plots")
        for ext in ("gp", "dat", "svg", "png", "pdf"):
            f = os.path.join(plots, "convergence_qi3." + ext)
            if not os.path.isfile(f) or os.path.getsize(f) == 0:
                fail(f"missing or empty {f}")
        with open(os.path.join(plots, "convergence_qi3.gp")) as f:
            gp = f.read()
        # energy, nodes, displacement (both methods); eps_t (bubble): 4 rows, 2 columns
        if "set multiplot layout 4,2 columnsfirst" not in gp:
            fail("convergence_qi3.gp: not 4 measures x 2 methods")
        for lab in ("energy", "nodes", "mean displacement per step", "eps_t (topological"):
            if f'set ylabel "{lab}' not in gp:
                fail(f"convergence_qi3.gp: no panel {lab}")
        for lab in ("phase 1: curves", "phase 3: faces", "phase 2: surface"):
            if f'set label "{lab}"' not in gp:
                fail(f"convergence_qi3.gp: no label {lab}")
        if gp.count("set arrow from") != 3:  # psys's phase 3 on its three panels
            fail("convergence_qi3.gp: not one phase boundary on each of psys's panels")
        if "not traced by psys" not in gp:
            fail("convergence_qi3.gp: psys's eps_t panel is not marked as untraced")
        if gp.count('title "mean of 2 seeds"') != 7:
            fail("convergence_qi3.gp: a mean line per panel with a measure (7)")
        if "set key outside" not in gp:
            fail("convergence_qi3.gp: the legend is not outside the data")
        with open(os.path.join(plots, "convergence_qi3.dat")) as f:
            dat = f.read()
        if dat.count("mean over its 2 seeds") != 2:
            fail("convergence_qi3.dat: no mean block per method")
        with open(os.path.join(plots, "convergence_qi3.svg")) as f:
            svg = f.read()
        for text in ("bubble", "psys", "each seed", "the mesh (node count)", "phase 3: faces", "step", "iteration"):
            if text not in svg:
                fail(f"convergence_qi3.svg does not show '{text}'")
        with open(os.path.join(plots, "convergence_boxhole.gp")) as f:
            gp = f.read()
        if 'set label "phase 3: volume"' not in gp:
            fail("convergence_boxhole.gp: bubble's volume phase is not labelled")
        with open(os.path.join(out, "report.md")) as f:
            md = f.read()
        if "ends on the mesh's node count" not in md:
            fail("report.md lacks the convergence caption")
        print("ok: 6 traces, convergence_qi3 and convergence_boxhole")
    finally:
        if not os.environ.get("PM_KEEP"): shutil.rmtree(tmp, ignore_errors=True)
        else: print("kept", tmp)


if __name__ == "__main__":
    main()
