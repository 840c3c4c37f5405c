#!/usr/bin/env python3
"""What a comparison report shows, through the packmesh binary:

  pictures  every (case, method) has plots/mesh_CASE_LABEL.png and .svg and a _worst zoom; the
            pictures of one case have one frame (same size); a picture is mostly mesh, not
            white; the SVG has one polygon per triangle of the run's mesh; the zoom's value is
            the run's largest R/l_min (elements.csv); report.html and report.md show them and
            say what drawing them cost.
  viewer    viewer/ holds three.js with its licence, viewer.js and one data file per case whose
            meshes are the runs' (triangle counts); in headless Chromium (tests/scripts/
            page_check.py) report.html loads with no console error, the viewer's canvas is not
            blank, a click on a triangle shows that triangle's values, unticking a method hides
            it. With PM_THREE_JS naming a missing file, or a three.js without a licence, the
            report says the viewer is not available and everything else is still written;
            PM_THREE_JS with a LICENSE beside it is copied with that licence.
  spread    over seeds 1 and 2: a method that ignores the seed gives byte-identical meshes, which
            results.csv marks (same_mesh_as) and the tables count as one distinct result; a
            method whose meshes differ has two and a spread (mean ± sd); the box plots pool a
            repeated mesh once, with Tukey's whiskers (the furthest values within 1.5 IQR) and
            every value beyond them as an outlier point, or min and max with "whiskers":
            "minmax"; "match": "surface" brings every method's surface nodes within 3% of the
            reference's (--target-surface-nodes) and the report says the matching was on surfaces.

    test_compare_report.py PACKMESH WORKDIR
"""
import csv
import json
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
        return None, None
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
    cost = re.search(r"The (\d+) pictures took ([0-9.]+) s to draw \(([0-9.]+) s of processor time; "
                     r"the runs: ([0-9.]+) s\)", md)
    if check(cost, "report.md does not say what the pictures cost"):
        check(int(cost.group(1)) == 4 * len(methods), "pictures counted: %s" % cost.group(1))
    return folder, rows


THREE = "/usr/share/javascript/three/three.min.js"
PAGE_CHECK = [os.environ.get("PM_PYTHON", "/usr/bin/python3"), os.path.join(SCRIPTS, "page_check.py")]

# Click the middle triangle of the last mesh shown, as a reader would (pointer events at its
# place on the canvas); the panel must name that triangle and its values.
CLICK_JS = """(function(){var v=window.pmViewer;var k=v.state.meshes.length-1;
var t=Math.floor(v.state.meshes[k].userData.method.tri.length/6);
var c=document.getElementById('pm-viewer-canvas');c.scrollIntoView();var xy=v.screenOf(k,t);
['pointerdown','pointerup'].forEach(function(n){c.dispatchEvent(new PointerEvent(n,
 {clientX:xy[0],clientY:xy[1],bubbles:true,pointerId:1}))});
var info=document.getElementById('pm-viewer-info').textContent;
return info.indexOf(v.state.meshes[k].userData.method.label+', triangle '+t+' ')===0
 && /R\\/l_min [0-9.]+, radius ratio [0-9.]+, smallest angle [0-9.]+ degrees/.test(info)})()"""
# Untick the first method: one mesh fewer, and the legend no longer names it first.
TOGGLE_JS = """(function(){var v=window.pmViewer;var n=v.state.meshes.length;
var box=document.querySelector('#pm-viewer-methods input');box.click();
return v.state.meshes.length===n-1})()"""


def viewer_data(folder, case):
    text = open(os.path.join(folder, "viewer", "mesh_%s.js" % case)).read()
    body = text[text.index(".push(") + 6:text.rindex(");")]
    return json.loads(body)


def test_viewer(folder, rows, methods):
    if not folder:
        return
    viewer = os.path.join(folder, "viewer")
    if not os.path.isfile(THREE):
        print("libjs-three is not installed: the viewer's files are not checked")
        return
    check(open(os.path.join(viewer, "three.min.js"), "rb").read() == open(THREE, "rb").read(),
          "viewer/three.min.js is not the system's three.js")
    check(open(os.path.join(viewer, "three.LICENSE")).read()
          == open("/usr/share/doc/libjs-three/copyright").read(), "viewer/three.LICENSE is not its licence")
    check("window.pmViewer" in open(os.path.join(viewer, "viewer.js")).read(), "viewer/viewer.js is not ours")
    html = open(os.path.join(folder, "report.html")).read()
    for case in ("qi1", "boxhole"):
        data = viewer_data(folder, case)
        check([m["label"] for m in data["methods"]] == [l for _, l in methods],
              "%s: the viewer's methods are %s" % (case, [m["label"] for m in data["methods"]]))
        check(data["flat"] == (case == "qi1"), "%s: flat is %s" % (case, data["flat"]))
        for m in data["methods"]:
            row = next(r for r in rows if r["case"] == case and r["label"] == m["label"])
            check(len(m["tri"]) == 3 * int(row["triangles"]) and len(m["xyz"]) == 3 * int(row["nodes"]),
                  "%s %s: the viewer has %d triangles, the run %s" % (case, m["label"], len(m["tri"]) // 3,
                                                                     row["triangles"]))
            check(len(m["values"]["aspect_ratio"]) == len(m["tri"]) // 3, "%s: one value per triangle" % case)
        check('<script src="viewer/mesh_%s.js"></script>' % case in html, "report.html does not load %s's data" % case)
    check(html.index('src="viewer/three.min.js"') < html.index('src="viewer/viewer.js"'),
          "three.js must load before viewer.js")
    run = subprocess.run(PAGE_CHECK + [os.path.join(folder, "report.html"), "--canvas", "#pm-viewer-canvas",
                                       "--eval", CLICK_JS, "--eval", TOGGLE_JS, "--expect-text", "3D viewer",
                                       "--expect-text", "Meshes"], capture_output=True, text=True)
    if run.returncode == 77:
        print("chromium is not installed: report.html is not loaded")
        return
    check(run.returncode == 0, "report.html in Chromium: %s%s" % (run.stdout, run.stderr))


def test_no_three(folder):
    """The same study written again (every run kept) without three.js, then with another one."""
    if not folder:
        return
    suite = os.path.join(WORK, "pictures.json")

    def rewrite(three):
        env = dict(os.environ, PM_THREE_JS=three)
        return subprocess.run([PACKMESH, "compare", suite, "-o", folder], capture_output=True, text=True, env=env)

    shutil.rmtree(os.path.join(folder, "viewer"))
    run = rewrite(os.path.join(WORK, "no-such-three.js"))
    check(run.returncode == 0, "compare without three.js exited %d: %s" % (run.returncode, run.stderr))
    html = open(os.path.join(folder, "report.html")).read()
    md = open(os.path.join(folder, "report.md")).read()
    gone = "The 3D viewer is not available: three.js was not found at %s" % os.path.join(WORK, "no-such-three.js")
    check(gone in html and gone in md, "the report does not say the viewer is unavailable")
    check("viewer/" not in html.replace(gone, ""), "report.html refers to viewer/ without three.js")
    check(not os.path.exists(os.path.join(folder, "viewer")), "viewer/ was written without three.js")
    check("<h2>Meshes</h2>" in html and '<img src="plots/mesh_qi1_' in html,
          "the pictures are gone from the report without three.js")
    if os.path.isfile(THREE):
        run = subprocess.run(PAGE_CHECK + [os.path.join(folder, "report.html"), "--expect-text", "not available"],
                             capture_output=True, text=True)
        check(run.returncode in (0, 77), "report.html without the viewer: %s" % run.stdout)
        # Another three.js: without a licence it is not copied; with a LICENSE beside it, it is.
        alt = os.path.join(WORK, "alt")
        shutil.rmtree(alt, ignore_errors=True)
        os.makedirs(alt)
        shutil.copy(THREE, os.path.join(alt, "three.min.js"))
        rewrite(os.path.join(alt, "three.min.js"))
        check("no licence file was found for %s" % os.path.join(alt, "three.min.js")
              in open(os.path.join(folder, "report.md")).read(), "a three.js without a licence was copied")
        check(not os.path.exists(os.path.join(folder, "viewer")), "viewer/ was written without a licence")
        with open(os.path.join(alt, "LICENSE"), "w") as f:
            f.write("The MIT License (test copy)\n")
        run = rewrite(os.path.join(alt, "three.min.js"))
        check(run.returncode == 0, "compare with PM_THREE_JS exited %d" % run.returncode)
        lic = os.path.join(folder, "viewer", "three.LICENSE")
        check(os.path.isfile(lic) and open(lic).read() == "The MIT License (test copy)\n",
              "PM_THREE_JS's LICENSE was not copied beside it")


def boxes(folder, name):
    """The box lines of plots/NAME.dat by method, and the outlier values by method."""
    box, out, method, outliers = {}, {}, None, False
    for line in open(os.path.join(folder, "plots", name + ".dat")):
        if line.startswith("# method "):
            method, outliers = line[9:].strip(), False
        elif line.startswith("# outliers of method "):
            method, outliers = line[21:line.index(":")].strip(), True
        elif line.strip() and not line.startswith("#"):
            f = line.split()
            if outliers:
                out.setdefault(method, []).append((float(f[0]), float(f[1])))
            else:
                box.setdefault(method, []).append(f)
    return box, out


def quartiles(v):
    """p25 and p75 by linear interpolation (summary.h's rule, NumPy's default)."""
    def q(p):
        h = (len(v) - 1) * p
        i = int(h)
        return v[i] + (h - i) * (v[min(i + 1, len(v) - 1)] - v[i])
    return q(0.25), q(0.75)


def test_spread(methods):
    names = [m for m, _ in methods]
    if "gmsh-frontal" not in names or "bubble" not in names:
        print("the spread checks need bubble and gmsh-frontal: skipped")
        return
    psys = subprocess.run([PACKMESH, "mesh", "--method", "psys", "--help"], capture_output=True).returncode == 0
    folder, rows = study("spread", '{"name": "spread", "cases": [{"input": "case:qi1", "size": 0.3},'
                         ' {"input": "case:boxhole", "volume": true, "size": 0.3}],'
                         ' "methods": ["bubble", "gmsh-frontal"%s], "seeds": [1, 2],'
                         ' "options": {"match_nodes": true, "match": "surface", "timeout_s": 120}}'
                         % (', {"method": "psys", "cases": ["qi1"]}' if psys else ""))
    if not folder:
        return
    by = {r["row"]: r for r in rows}
    for r in rows:
        check(r["status"] == "ok", "%s: %s %s" % (r["row"], r["status"], r["error"]))
    # gmsh's meshes do not depend on the seed: the second is the first's, byte for byte.
    for case in ("qi1", "boxhole"):
        first, second = "%s__gmsh-frontal__s1" % case, "%s__gmsh-frontal__s2" % case
        check(by[second]["same_mesh_as"] == first, "%s: same_mesh_as is '%s'" % (second, by[second]["same_mesh_as"]))
        check(by[first]["same_mesh_as"] == "", "%s: same_mesh_as is '%s'" % (first, by[first]["same_mesh_as"]))
    md = open(os.path.join(folder, "report.md")).read()
    table = md[md.index("### qi1"):md.index("### boxhole")]
    gm = re.search(r"^\| gmsh-frontal \| 2/2 \| (\d+) \|", table, re.M)
    check(gm and gm.group(1) == "1", "qi1: gmsh-frontal's two identical runs are not one distinct result")
    check("| distinct |" in table, "the summary table has no 'distinct' column")
    if psys:
        check(by["qi1__psys__s2"]["same_mesh_as"] == "", "psys's seeds gave identical meshes")
        ps = re.search(r"^\| psys \| 2/2 \| 2 \| [^|]+ \| [^|]+ \| ([^|]+) \|", table, re.M)
        check(ps and re.match(r"\s*[0-9.]+ ± [0-9.e-]+\s*$", ps.group(1)),
              "psys's mean radius ratio over two distinct meshes has no spread: %s" % (ps and ps.group(1)))
    # A repeated mesh is pooled once: gmsh-frontal's box on qi1 has one run's triangles.
    box, outliers = boxes(folder, "aspect_tri")
    qi1_box = next(f for f in box["gmsh-frontal"] if f[7] == "qi1")
    check(int(qi1_box[6]) == int(by["qi1__gmsh-frontal__s1"]["triangles"]),
          "gmsh-frontal's qi1 box pools %s triangles, not one run's %s" % (qi1_box[6], by["qi1__gmsh-frontal__s1"]["triangles"]))
    check(any(outliers.values()), "no box of the study has an outlier to check")
    # Tukey's whiskers, against the elements themselves.
    with open(os.path.join(folder, "elements.csv")) as f:
        elements = list(csv.DictReader(f))
    for method, lines in box.items():
        for f in lines:
            keep = [r["row"] for r in rows if r["case"] == f[7] and r["label"] == method and r["same_mesh_as"] == ""]
            v = sorted(float(e["aspect_ratio"]) for e in elements if e["row"] in keep and e["kind"] == "tri")
            p25, p75 = quartiles(v)
            lo, hi = p25 - 1.5 * (p75 - p25), p75 + 1.5 * (p75 - p25)
            inside = [x for x in v if lo <= x <= hi]
            check(abs(float(f[1]) - inside[0]) <= 1e-8 and abs(float(f[5]) - inside[-1]) <= 1e-8,
                  "%s %s: whiskers %s %s, Tukey's %g %g" % (method, f[7], f[1], f[5], inside[0], inside[-1]))
            beyond = sorted({float("%.4g" % x) for x in v if x < lo or x > hi})
            shown = sorted(val for x, val in outliers.get(method, []) if x == float(f[0]))
            check(shown == beyond, "%s %s: %d outliers beyond the whiskers, %d drawn"
                  % (method, f[7], len(beyond), len(shown)))
    # Surface matching: every method within 3% of the reference's surface nodes, and said so.
    for r in rows:
        if r["label"] == "bubble":
            continue
        ref = by["%s__bubble__s%s" % (r["case"], r["seed"])]
        rel = float(r["surface_nodes"]) / float(ref["surface_nodes"]) - 1
        check(abs(rel) <= 0.03, "%s: %s surface nodes, the reference %s (%+.1f%%)"
              % (r["row"], r["surface_nodes"], ref["surface_nodes"], 100 * rel))
        check("--target-surface-nodes %s " % ref["surface_nodes"] in r["command"],
              "%s: the command does not match surface nodes: %s" % (r["row"], r["command"]))
    check("matched to bubble's on the surface nodes" in md, "the summary does not say the matching was on surfaces")
    check("matched on the surface nodes" in md, "the inputs do not say the matching was on surfaces")

    # "whiskers": "minmax" keeps the min and the max, with no outlier.
    folder, rows = study("minmax", '{"name": "minmax", "cases": [{"input": "case:qi1", "size": 0.3}],'
                         ' "methods": ["bubble"], "options": {"whiskers": "minmax"}}')
    if folder:
        box, outliers = boxes(folder, "aspect_tri")
        with open(os.path.join(folder, "elements.csv")) as f:
            v = sorted(float(e["aspect_ratio"]) for e in csv.DictReader(f) if e["kind"] == "tri")
        f = box["bubble"][0]
        check(float(f[1]) == float("%.9g" % v[0]) and float(f[5]) == float("%.9g" % v[-1]) and not outliers,
              "minmax whiskers: %s %s, elements %g %g, outliers %s" % (f[1], f[5], v[0], v[-1], outliers))
        check("the whiskers reach the minimum and the maximum" in open(os.path.join(folder, "report.md")).read(),
              "the caption does not say the whiskers are min and max")


def main():
    os.makedirs(WORK, exist_ok=True)
    found = methods_of_build()
    if not found:
        print("skipped: this build has none of gmsh-frontal, bubble, cgal")
        return 77
    # Two entries (two labels) even when the build has one method.
    methods = [(found[0], found[0]), (found[1] if len(found) > 1 else found[0],
                                      found[1] if len(found) > 1 else found[0] + "-2")]
    folder, rows = test_pictures(methods)
    test_viewer(folder, rows, methods)
    test_no_three(folder)
    test_spread(methods)
    if failures:
        print("%d failure(s)" % len(failures))
        return 1
    shutil.rmtree(WORK, ignore_errors=True)
    print("report checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
