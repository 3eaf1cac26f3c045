#!/usr/bin/python3
"""Draws the images `piezoloop scan` formed, one PNG each.

Usage: plot_image.py IMAGES.json   (run with Debian's /usr/bin/python3, which
has matplotlib). The C++ side forms the images; this script only draws them.
IMAGES.json:

  {"images": [{"out": "path.png", "title": str, "clabel": str,
               "cmap": str (optional, default "viridis"),
               "nx": int, "ny": int,
               "extent_um": [x_left, x_right, y_bottom, y_top],
               "values": [row-major, row 0 at the bottom; null: no pixel]}]}

Cells without a pixel are drawn grey. Exits non-zero with a message on bad
input."""
import json
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def draw(img):
    nx, ny = int(img["nx"]), int(img["ny"])
    values = np.array([np.nan if v is None else float(v) for v in img["values"]], dtype=float)
    if values.size != nx * ny:
        raise ValueError(f"{img['out']}: {values.size} values for {nx} x {ny} cells")
    grid = np.ma.masked_invalid(values.reshape(ny, nx))
    cmap = plt.get_cmap(img.get("cmap", "viridis")).copy()
    cmap.set_bad("0.7")
    fig, ax = plt.subplots(figsize=(5.6, 4.8))
    im = ax.imshow(grid, origin="lower", extent=img["extent_um"], cmap=cmap, interpolation="nearest", aspect="equal")
    fig.colorbar(im, ax=ax, label=img.get("clabel", ""))
    ax.set_xlabel("x (µm)")
    ax.set_ylabel("y (µm)")
    ax.set_title(img.get("title", ""), fontsize=10)
    fig.tight_layout()
    fig.savefig(img["out"], dpi=100)
    plt.close(fig)


def main(argv):
    if len(argv) != 2:
        print("usage: plot_image.py IMAGES.json", file=sys.stderr)
        return 2
    with open(argv[1]) as f:
        spec = json.load(f)
    images = spec.get("images", [])
    if not images:
        print("plot_image.py: no images to draw", file=sys.stderr)
        return 2
    try:
        for img in images:
            draw(img)
    except (KeyError, ValueError) as e:
        print(f"plot_image.py: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
