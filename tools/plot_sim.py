#!/usr/bin/python3
"""Figures of the simulator (`piezoloop sim --plot`, `piezoloop reproduce`).

Usage: /usr/bin/python3 tools/plot_sim.py FIGURES.json

FIGURES.json is one figure or a list of figures. A figure is
    {"output": "/abs/path.png", "title": "...", "columns": 2 (optional),
     "panels": [{"title": "...", "xlabel": "...", "ylabel": "...",
                 "xscale": "linear|log", "yscale": "linear|log",
                 "series": [{"label": "...", "x": [...], "y": [...],
                             "style": "o-" (optional matplotlib format)}]}]}
or, from `piezoloop sim --plot`, {"kind": "sim", "output": ..., "title": ...,
"t_s": [...], "r_um": [...], "y_um": [...], "u_V": [...],
"window_start_s": t}, drawn as reference/output, error and the loop of the
measured period.

Needs matplotlib (Debian's python3-matplotlib): run it with /usr/bin/python3.
"""
import json
import math
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def sim_panels(spec):
    t, r, y, u = spec["t_s"], spec["r_um"], spec["y_um"], spec["u_V"]
    t0 = spec.get("window_start_s", 0.0)
    e = [a - b for a, b in zip(r, y)]
    scale, unit = (1e3, "ms") if (t[-1] if t else 0) < 0.5 else (1.0, "s")
    ts = [v * scale for v in t]
    win = [i for i, v in enumerate(t) if v >= t0]
    return [
        {"title": "reference and output", "xlabel": f"time ({unit})", "ylabel": "µm",
         "series": [{"label": "r", "x": ts, "y": r, "style": "k--"}, {"label": "y", "x": ts, "y": y}]},
        {"title": "tracking error", "xlabel": f"time ({unit})", "ylabel": "e = r − y (µm)",
         "series": [{"label": "e", "x": ts, "y": e}]},
        {"title": "command", "xlabel": f"time ({unit})", "ylabel": "u (V)",
         "series": [{"label": "u", "x": ts, "y": u}]},
        {"title": "measured period: output against reference", "xlabel": "r (µm)", "ylabel": "y (µm)",
         "series": [{"label": "y(r)", "x": [r[i] for i in win], "y": [y[i] for i in win]}]},
    ]


def draw(fig_spec):
    panels = sim_panels(fig_spec) if fig_spec.get("kind") == "sim" else fig_spec["panels"]
    n = max(1, len(panels))
    cols = fig_spec.get("columns", 1 if n <= 2 else 2)
    rows = math.ceil(n / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(6.4 * cols, 3.6 * rows), squeeze=False)
    for i, p in enumerate(panels):
        ax = axes[i // cols][i % cols]
        for s in p.get("series", []):
            x, y = s["x"], s["y"]
            if not x:
                continue
            style = s.get("style")
            if style:
                ax.plot(x, y, style, label=s.get("label"), markersize=3, linewidth=1.2)
            else:
                ax.plot(x, y, label=s.get("label"), linewidth=1.2)
        ax.set_title(p.get("title", ""), fontsize=10)
        ax.set_xlabel(p.get("xlabel", ""))
        ax.set_ylabel(p.get("ylabel", ""))
        if p.get("xscale"):
            ax.set_xscale(p["xscale"])
        if p.get("yscale"):
            ax.set_yscale(p["yscale"])
        ax.grid(True, which="both", alpha=0.3)
        if len(p.get("series", [])) > 1:
            ax.legend(fontsize=8)
    for j in range(n, rows * cols):
        axes[j // cols][j % cols].axis("off")
    fig.suptitle(fig_spec.get("title", ""), fontsize=11)
    fig.tight_layout()
    fig.savefig(fig_spec["output"], dpi=110)
    plt.close(fig)


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    with open(sys.argv[1]) as f:
        spec = json.load(f)
    figures = spec if isinstance(spec, list) else [spec]
    for fig in figures:
        draw(fig)
        print("wrote", fig["output"])


if __name__ == "__main__":
    main()
