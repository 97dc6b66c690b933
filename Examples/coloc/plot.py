#!/usr/bin/env python3
"""Draws the plots of the `coloc` CLI with matplotlib (Agg backend: no display needed).

Usage: plot.py DESCRIPTION.json OUT --format png|pdf|svg

DESCRIPTION.json (written by Examples/coloc/plot.cpp):
  {"panels": [{"title": str, "x_label": str, "y_label": str, "equal_aspect": bool,
               "series": [{"label": str, "x": [float], "y": [float], "colour": str}]}]}
Panels are drawn side by side, each with axes, ticks, a grid and a legend.

Exit codes: 0 written, 2 bad description, 3 matplotlib missing, 1 anything else.
"""
import argparse
import json
import sys


def draw_panel(ax, panel):
    for series in panel["series"]:
        style = {"label": series.get("label") or None, "linewidth": 1.4}
        if series.get("colour"):
            style["color"] = series["colour"]
        if len(series["x"]) == 1:
            style["marker"] = "o"  # a single sample is a point, not an invisible line
        ax.plot(series["x"], series["y"], **style)
    ax.set_title(panel.get("title", ""))
    ax.set_xlabel(panel.get("x_label", ""))
    ax.set_ylabel(panel.get("y_label", ""))
    ax.grid(True, alpha=0.3)
    if panel.get("equal_aspect"):
        # Metres on both axes: a square on the floor stays a square in the picture.
        ax.set_aspect("equal", adjustable="datalim")
    if any(s.get("label") for s in panel["series"]):
        ax.legend(loc="best")


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("description")
    p.add_argument("out")
    p.add_argument("--format", default="png", choices=["png", "pdf", "svg"])
    args = p.parse_args()
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as e:
        print(f"matplotlib is not installed for {sys.executable} ({e})", file=sys.stderr)
        return 3
    try:
        with open(args.description, encoding="utf-8") as f:
            panels = json.load(f)["panels"]
        if not panels:
            raise ValueError("no panels")
    except (OSError, ValueError, KeyError, TypeError) as e:
        print(f"{args.description}: bad plot description: {e}", file=sys.stderr)
        return 2
    fig, axes = plt.subplots(1, len(panels), figsize=(6.4 * len(panels), 5.2), squeeze=False)
    for ax, panel in zip(axes[0], panels):
        draw_panel(ax, panel)
    fig.tight_layout()
    fig.savefig(args.out, format=args.format, dpi=110)
    return 0


if __name__ == "__main__":
    sys.exit(main())
