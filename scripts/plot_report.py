#!/usr/bin/env python3
"""Draws DIR/report.png from the files of a flexcloud run in DIR.

usage: plot_report.py DIR

Left: top view of the corrected trajectory coloured by the correction the rubber sheet applied
(distance between the rigidly aligned and the corrected pose), the GNSS, the control points and
the fixes the fusion rejected. Right: deviation from the GNSS along the drive, after the rigid
alignment and after the rubber sheet. Exit 3 when matplotlib is missing, 1 on bad input.
"""
import os
import sys

try:
    import numpy as np
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError as e:
    print(f"plot_report: {e}", file=sys.stderr)
    sys.exit(3)


def load(path, usecols=None, dtype=float):
    """Rows of a whitespace table ('#' comments), as a 2D array (0 rows when absent or empty)."""
    if not os.path.exists(path) or os.path.getsize(path) == 0:
        return np.zeros((0, len(usecols) if usecols else 8))
    a = np.loadtxt(path, comments="#", usecols=usecols, dtype=dtype, ndmin=2)
    return a


def rejected_fixes(path):
    """x, y of the fixes the fusion rejected as outliers."""
    if not os.path.exists(path):
        return np.zeros((0, 2))
    rows = []
    with open(path) as f:
        for line in f:
            parts = line.split()
            if line.startswith("#") or len(parts) < 7 or parts[6] != "outlier":
                continue
            rows.append((float(parts[1]), float(parts[2])))
    return np.array(rows).reshape(-1, 2)


def thinned(n, most=4000):
    """Every k-th of n rows, k chosen so that at most `most` remain: markers closer than a pixel
    cost drawing time and show nothing more."""
    return slice(None, None, max(1, -(-n // most)))


def matching_rows(times, wanted):
    """For each of `wanted` (s), the row of `times` with the same stamp to the microsecond, -1
    where there is none."""
    if len(times) == 0:
        return np.full(len(wanted), -1, dtype=np.int64)
    keys = np.round(times * 1e6).astype(np.int64)
    order = np.argsort(keys, kind="stable")
    probe = np.round(wanted * 1e6).astype(np.int64)
    pos = np.minimum(np.searchsorted(keys[order], probe), len(keys) - 1)
    return np.where(keys[order][pos] == probe, order[pos], -1)


def along(positions):
    """Distance travelled at each pose, m."""
    steps = np.linalg.norm(np.diff(positions[:, :2], axis=0), axis=1)
    return np.concatenate([[0.0], np.cumsum(steps)])


def main(folder):
    gnss = load(os.path.join(folder, "trajectory_gnss.txt"))
    aligned = load(os.path.join(folder, "trajectory_aligned.txt"))
    corrected = load(os.path.join(folder, "trajectory_rubbersheet.txt"))
    cps = load(os.path.join(folder, "control_points.txt"))
    rejected = rejected_fixes(os.path.join(folder, "gnss_fixes.txt"))
    if len(corrected) == 0 or len(aligned) != len(corrected):
        print("plot_report: the trajectories are missing or differ in length", file=sys.stderr)
        return 1
    correction = np.linalg.norm(corrected[:, 1:4] - aligned[:, 1:4], axis=1)
    s = along(corrected[:, 1:4])

    fig, (top, dev) = plt.subplots(1, 2, figsize=(15, 6.5), gridspec_kw={"width_ratios": [1.1, 1]})
    if len(gnss):
        top.plot(gnss[:, 1], gnss[:, 2], color="0.7", lw=3, label="GNSS at the poses", zorder=1)
    k = thinned(len(corrected))
    sc = top.scatter(corrected[k, 1], corrected[k, 2], c=correction[k], s=4, cmap="viridis",
                     zorder=2)
    fig.colorbar(sc, ax=top, label="correction by the rubber sheet (m)")
    if len(cps):
        top.scatter(cps[:, 5], cps[:, 6], marker="x", color="k", s=18, lw=0.8,
                    label=f"control points ({len(cps)})", zorder=3)
    if len(rejected):
        top.scatter(rejected[:, 0], rejected[:, 1], color="red", s=10,
                    label=f"rejected fixes ({len(rejected)})", zorder=4)
    top.set_aspect("equal", adjustable="datalim")
    top.set_xlabel("east (m)")
    top.set_ylabel("north (m)")
    top.set_title("Corrected trajectory, top view (ENU)")
    top.legend(loc="best", fontsize=8)

    if len(gnss):
        rows = matching_rows(corrected[:, 0], gnss[:, 0])
        keep = rows >= 0
        idx = rows[keep]
        g = gnss[keep, 1:4]
        before = np.linalg.norm(aligned[idx, 1:4] - g, axis=1)
        after = np.linalg.norm(corrected[idx, 1:4] - g, axis=1)
        dev.plot(s[idx], before, lw=0.8, color="tab:orange",
                 label=f"rigid alignment (mean {before.mean():.3f} m)")
        dev.plot(s[idx], after, lw=0.8, color="tab:blue",
                 label=f"rubber sheet (mean {after.mean():.3f} m)")
        dev.legend(loc="upper right", fontsize=8)
    dev.set_xlabel("distance along the drive (m)")
    dev.set_ylabel("deviation from the GNSS (m)")
    dev.set_title("Deviation from the GNSS along the drive")
    dev.grid(alpha=0.3)
    fig.suptitle(f"flexcloud: {len(corrected)} poses, {len(cps)} control points, "
                 f"{len(rejected)} fixes rejected", fontsize=10)
    # A fixed layout: tight_layout measured every label again (0.1 s of a city run's plot).
    fig.subplots_adjust(left=0.065, right=0.985, bottom=0.09, top=0.9, wspace=0.12)
    fig.savefig(os.path.join(folder, "report.png"), dpi=110, pil_kwargs={"compress_level": 3})
    return 0


if __name__ == "__main__":
    if len(sys.argv) != 2 or sys.argv[1] in ("-h", "--help"):
        print(__doc__.strip().splitlines()[2])
        sys.exit(0 if len(sys.argv) == 2 else 2)
    sys.exit(main(sys.argv[1]))
