#!/usr/bin/python3
"""Draws the curves `piezoloop analyze ... --plot FILE.png` computed.

Usage: plot.py FIGURES.json OUT.png   (run with Debian's /usr/bin/python3,
which has matplotlib). The C++ side decides what to draw; this script only
lays it out. FIGURES.json:

  {"title": str,
   "panels": [{"title": str, "xlabel": str, "ylabel": str,
               "xscale": "log"|"linear", "yscale": "log"|"linear" (optional),
               "ylim": [lo, hi] (optional),
               "series": [{"label": str, "x": [...], "y": [...], "style": "-"|"--"|":"}],
               "hlines": [{"y": float, "label": str}],
               "vlines": [{"x": float, "label": str}]}]}

One panel per row, sharing nothing; exits non-zero with a message on bad
input."""
import json
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main(argv):
    if len(argv) != 3:
        print("usage: plot.py FIGURES.json OUT.png", file=sys.stderr)
        return 2
    with open(argv[1]) as f:
        spec = json.load(f)
    panels = spec.get("panels", [])
    if not panels:
        print("plot.py: no panels to draw", file=sys.stderr)
        return 2
    fig, axes = plt.subplots(len(panels), 1, figsize=(8, 3.2 * len(panels)), squeeze=False)
    for ax, p in zip(axes[:, 0], panels):
        for s in p.get("series", []):
            if s["x"]:
                ax.plot(s["x"], s["y"], s.get("style", "-"), label=s.get("label", ""), linewidth=1.2)
        for h in p.get("hlines", []):
            ax.axhline(h["y"], color="grey", linestyle=":", linewidth=1, label=h.get("label"))
        for v, colour in zip(p.get("vlines", []), ["tab:red", "tab:purple", "tab:olive", "tab:cyan"] * 8):
            ax.axvline(v["x"], color=colour, linestyle=":", linewidth=1, label=v.get("label"))
        ax.set_xscale(p.get("xscale", "linear"))
        ax.set_yscale(p.get("yscale", "linear"))
        if "ylim" in p:
            ax.set_ylim(*p["ylim"])
        ax.set_title(p.get("title", ""), fontsize=10)
        ax.set_xlabel(p.get("xlabel", ""))
        ax.set_ylabel(p.get("ylabel", ""))
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8, loc="best")
    fig.suptitle(spec.get("title", ""), fontsize=11)
    fig.tight_layout()
    fig.savefig(argv[2], dpi=110)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
