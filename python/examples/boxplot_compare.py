#!/usr/bin/env python3
"""Compare bubble, psys and gmsh's Frontal-Delaunay on Qi's third domain at matched node counts,
and draw a box plot of the triangles' radius ratio per method.

    boxplot_compare.py OUT.png [--study DIR] [--jobs N]

The study runs through packmesh.compare (the packmesh command's comparison engine): bubble first,
then psys and gmsh-frontal with their size fields scaled until their node counts are within 3%
of bubble's. The per-element values come from the study's elements.csv. The study folder (default:
OUT's folder/boxplot-study) keeps the runs, results.csv and the engine's own report; running
again into it redoes nothing.
"""
import argparse
import os
import sys

import matplotlib

matplotlib.use("Agg")  # files only, no display needed
import matplotlib.pyplot as plt  # noqa: E402 (after the backend is chosen)

import packmesh  # noqa: E402

SUITE = {
    "name": "qi3-boxplot",
    "description": "papers/004's third domain, three methods at bubble's node count",
    "cases": ["case:qi3"],
    "methods": ["bubble", "psys", "gmsh-frontal"],
    "options": {"match_nodes": True, "reference": "bubble", "trace": False},
}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("png", help="the box plot to write (PNG)")
    parser.add_argument("--study", help="the study folder (default: beside the PNG)")
    parser.add_argument("--jobs", type=int, default=None, help="runs at once")
    args = parser.parse_args()
    png = os.path.abspath(args.png)
    study_dir = args.study or os.path.join(os.path.dirname(png), "boxplot-study")

    study = packmesh.compare(SUITE, study_dir, jobs=args.jobs)
    failed = [r for r in study.rows if r["status"] != "ok"]
    for r in failed:
        print(f"boxplot_compare: {r['method']} {r['status']}: {r['error']}", file=sys.stderr)
    if failed:
        return 1

    tri = study.elements(kind="tri")
    labels, values = [], []
    for r in study.rows:
        mine = tri["row"] == r["row"]
        labels.append(f"{r['label']}\n{r['nodes']} nodes")
        values.append(tri["radius_ratio"][mine])

    fig, ax = plt.subplots(figsize=(6, 4), dpi=150)
    # Whiskers at the extremes: papers/001 Fig. 11 shows min, p25, median, p75, max.
    ax.boxplot(values, labels=labels, whis=(0, 100), widths=0.5)
    ax.set_ylabel("triangle radius ratio 2 r / R (1 = equilateral)")
    ax.set_title("case:qi3 at matched node counts")
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(png)
    print(f"boxplot_compare: {png} (study: {study.outdir}, report: {study.report})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
