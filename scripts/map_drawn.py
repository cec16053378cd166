#!/usr/bin/env python3
"""Prints the share of the rviz 3D view (a screenshot) covered by coloured points.

usage: map_drawn.py SHOT.png
The view is the window's middle (the panels lie at its sides); a point counts where its colour
is saturated (the map is coloured by height, the background is grey), so the grid and the
text do not. The trajectories are coloured too, but cover a few thousandths of the view; the
map covers percents.
"""
import sys

import numpy as np
from PIL import Image


def drawn_share(path):
    rgb = np.asarray(Image.open(path).convert("RGB"), dtype=np.int16)
    h, w, _ = rgb.shape
    view = rgb[h // 8: h - h // 8, w // 4: w - w // 5]
    saturation = view.max(axis=2) - view.min(axis=2)
    return float((saturation > 60).mean())


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: map_drawn.py SHOT.png")
    print(f"{drawn_share(sys.argv[1]):.4f}")
