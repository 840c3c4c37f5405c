#!/usr/bin/env python3
"""What a comparison report shows, through the packmesh binary:

  pictures  every (case, method) has plots/mesh_CASE_LABEL.png and .svg and a _worst zoom; the
            pictures of one case have one frame (same size); a picture is mostly mesh, not
            white; the SVG has one polygon per triangle of the run's mesh; the zoom's value is
            the run's largest R/l_min (elements.csv); report.html and report.md show them and
            say what drawing them cost.

    test_compare_report.py PACKMESH WORKDIR
"""
import csv
import os
import re
import shutil
import subprocess
import sys

# The PNG reader of the page checker (tests/scripts/page_check.py), which the viewer's checks run.
SCRIPTS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scripts")
sys.path.insert(0, SCRIPTS)
from page_check import not_blank_fraction, png_pixels  # noqa: E402

PACKMESH, WORK = sys.argv[1], sys.argv[2]
failures = []


def check(cond, what):
    if not cond:
        failures.append(what)
        print("FAIL:", what)
    return cond


def methods_of_build():
    found = []
    for m in ("gmsh-frontal", "bubble", "cgal"):
        if subprocess.run([PACKMESH, "mesh", "--method", m, "--help"], capture_output=True).returncode == 0:
            found.append(m)
    return found


def study(name, suite, env=None):
    folder = os.path.join(WORK, name)
    shutil.rmtree(folder, ignore_errors=True)
    path = os.path.join(WORK, name + ".json")
    with open(path, "w") as f:
        f.write(suite)
    run = subprocess.run([PACKMESH, "compare", path, "-o", folder, "--jobs", "2"], capture_output=True,
                         text=True, env=env)
    if not check(run.returncode == 0, "%s: compare exited %d: %s" % (name, run.returncode, run.stderr[-2000:])):
        return None, None
    with open(os.path.join(folder, "results.csv")) as f:
        rows = list(csv.DictReader(f))
    return folder, rows


def test_pictures(methods):
    entries = ", ".join('{"method": "%s", "label": "%s"}' % (m, l) for m, l in methods)
    folder, rows = study("pictures", '{"name": "pictures", "cases": [{"input": "case:qi1", "size": 0.3},'
                         ' {"input": "case:boxhole", "volume": true, "size": 0.35}],'
                         ' "methods": [%s], "options": {"timeout_s": 120}}' % entries)
    if not folder:
        return
    html = open(os.path.join(folder, "report.html")).read()
    md = open(os.path.join(folder, "report.md")).read()
    with open(os.path.join(folder, "elements.csv")) as f:
        elements = list(csv.DictReader(f))
    for case in ("qi1", "boxhole"):
        sizes = set()
        for _, label in methods:
            row = next(r for r in rows if r["case"] == case and r["label"] == label)
            check(row["status"] == "ok", "%s %s: %s" % (case, label, row["error"]))
            stem = os.path.join(folder, "plots", "mesh_%s_%s" % (case, label))
            for tail in ("", "_worst"):
                for ext in (".png", ".svg"):
                    check(os.path.isfile(stem + tail + ext), "missing %s" % (stem + tail + ext))
            if not os.path.isfile(stem + ".png"):
                continue
            png = open(stem + ".png", "rb").read()
            w, h, _ = png_pixels(png)
            sizes.add((w, h))
            ink = not_blank_fraction(png)  # the most common colour is the white background
            check(ink > 0.2, "%s: only %.0f%% of the picture is drawn" % (stem, 100 * ink))
            svg = open(stem + ".svg").read()
            polygons = svg.count("<polygon")
            check(polygons == int(row["triangles"]),
                  "%s.svg: %d polygons for %s triangles" % (stem, polygons, row["triangles"]))
            kind = "tet" if case == "boxhole" else "tri"
            worst = max(float(e["aspect_ratio"]) for e in elements
                        if e["row"] == row["row"] and e["kind"] == kind)
            caption = re.search(r"%s's worst %s: R/l_min ([0-9.e+-]+)" % (re.escape(label),
                                "tet" if kind == "tet" else "triangle"), md)
            if check(caption, "report.md has no caption of %s's worst element on %s" % (label, case)):
                check(abs(float(caption.group(1)) - worst) <= 1e-3 * worst,
                      "%s %s: the zoom says %s, elements.csv's largest R/l_min is %g"
                      % (case, label, caption.group(1), worst))
            name = "plots/mesh_%s_%s.png" % (case, label)
            check('<img src="%s"' % name in html, "report.html does not show %s" % name)
            check("](%s)" % name in md, "report.md does not show %s" % name)
            worst_name = "plots/mesh_%s_%s_worst.png" % (case, label)
            check('<img src="%s"' % worst_name in html, "report.html does not show %s" % worst_name)
        check(len(sizes) == 1, "%s: the methods' pictures differ in size %s (one frame per case)" % (case, sizes))
    cost = re.search(r"The (\d+) pictures took ([0-9.]+) s to draw \(the runs: ([0-9.]+) s\)", md)
    if check(cost, "report.md does not say what the pictures cost"):
        check(int(cost.group(1)) == 4 * len(methods), "pictures counted: %s" % cost.group(1))


def main():
    os.makedirs(WORK, exist_ok=True)
    found = methods_of_build()
    if not found:
        print("skipped: this build has none of gmsh-frontal, bubble, cgal")
        return 77
    # Two entries (two labels) even when the build has one method.
    methods = [(found[0], found[0]), (found[1] if len(found) > 1 else found[0],
                                      found[1] if len(found) > 1 else found[0] + "-2")]
    test_pictures(methods)
    if failures:
        print("%d failure(s)" % len(failures))
        return 1
    shutil.rmtree(WORK, ignore_errors=True)
    print("report checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
