#!/usr/bin/env python3
"""Draws DIR/report.png from the files of a flexcloud run in DIR.

usage: plot_report.py DIR   (or -: DIR is read from the first line of standard input)

Left: top view of the corrected trajectory coloured by how far it may lie from the truth (its
1-sigma per horizontal axis, trajectory_sigma.txt; without that file, by the correction the
rubber sheet applied), the GNSS on top of it, the control points and the fixes the fusion
rejected, down-weighted or found above the std-dev threshold. Right: along the drive, the band
within which 95 % of the poses lie from the truth (2.45 sigma), and the deviation from the GNSS
after the rigid alignment and after the rubber sheet, with a tick where such fixes were. Exit 3
when matplotlib is missing, 1 on bad input.
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


# Weight below which the fusion's robust loss has taken nine tenths of a fix's pull (a good
# fix one sigma off keeps about half).
DOWN_WEIGHTED = 0.1


def judged_fixes(path):
    """The fixes of gnss_fixes.txt by what the fusion made of them: a dict of stamp, x, y rows
    (N x 3) for "rejected" (outliers), "down-weighted" (used, weight under DOWN_WEIGHTED) and
    "above threshold" (std-dev above stddev_threshold: no control point there)."""
    rows = {"rejected": [], "down-weighted": [], "above threshold": []}
    if os.path.exists(path):
        with open(path) as f:
            for line in f:
                parts = line.split()
                if line.startswith("#") or len(parts) < 7:
                    continue
                row = (float(parts[0]), float(parts[1]), float(parts[2]))
                verdict, weight = parts[6], float(parts[5])
                if verdict == "outlier":
                    rows["rejected"].append(row)
                elif verdict == "above_std_threshold":
                    rows["above threshold"].append(row)
                elif verdict == "used" and weight < DOWN_WEIGHTED:
                    rows["down-weighted"].append(row)
    return {k: np.array(v).reshape(-1, 3) for k, v in rows.items()}


# How each kind of judged fix is drawn: colour, marker size, drawing order.
FIX_STYLE = {"rejected": ("red", 10, 6), "down-weighted": ("tab:orange", 8, 5),
             "above threshold": ("tab:purple", 6, 4)}


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
    judged = judged_fixes(os.path.join(folder, "gnss_fixes.txt"))
    if len(corrected) == 0 or len(aligned) != len(corrected):
        print("plot_report: the trajectories are missing or differ in length", file=sys.stderr)
        return 1
    sigma = load(os.path.join(folder, "trajectory_sigma.txt"), usecols=(0, 1, 2))
    if len(sigma) != len(corrected):
        sigma = np.zeros((0, 3))
    correction = np.linalg.norm(corrected[:, 1:4] - aligned[:, 1:4], axis=1)
    s = along(corrected[:, 1:4])

    fig = plt.figure(figsize=(15, 6.5))
    grid = fig.add_gridspec(2, 2, width_ratios=[1.1, 1], height_ratios=[1, 1.6], hspace=0.35)
    top = fig.add_subplot(grid[:, 0])
    truth = fig.add_subplot(grid[0, 1])
    dev = fig.add_subplot(grid[1, 1], sharex=truth)
    k = thinned(len(corrected))
    if len(sigma):
        sc = top.scatter(corrected[k, 1], corrected[k, 2], c=sigma[k, 1], s=6, cmap="plasma",
                         vmin=0.0, vmax=max(float(np.percentile(sigma[:, 1], 99)), 1e-3), zorder=1)
        fig.colorbar(sc, ax=top, label="how far from the truth: 1-sigma per axis (m)")
    else:
        sc = top.scatter(corrected[k, 1], corrected[k, 2], c=correction[k], s=4, cmap="viridis",
                         zorder=1)
        fig.colorbar(sc, ax=top, label="correction by the rubber sheet (m)")
    if len(gnss):
        # On top of the trajectory, thin: where the two part, both show.
        top.plot(gnss[:, 1], gnss[:, 2], color="tab:cyan", lw=0.8, label="GNSS at the poses",
                 zorder=2)
    if len(cps):
        top.scatter(cps[:, 5], cps[:, 6], marker="x", color="k", s=18, lw=0.8,
                    label=f"control points ({len(cps)})", zorder=3)
    for kind, fixes in judged.items():
        if len(fixes):
            color, size, order = FIX_STYLE[kind]
            top.scatter(fixes[:, 1], fixes[:, 2], color=color, s=size, zorder=order,
                        label=f"{kind} fixes ({len(fixes)})")
    top.set_aspect("equal", adjustable="datalim")
    top.set_xlabel("east (m)")
    top.set_ylabel("north (m)")
    top.set_title("Corrected trajectory, top view (ENU)")
    top.legend(loc="best", fontsize=8)

    if len(sigma):
        band = 2.45 * sigma[:, 1]
        truth.fill_between(s, 0.0, band, color="tab:green", alpha=0.35, lw=0,
                           label=f"horizontal: 2.45 sigma (median {np.median(band):.3f} m)")
        truth.plot(s, 1.96 * sigma[:, 2], color="tab:brown", lw=0.8,
                   label=f"vertical: 1.96 sigma (median {np.median(1.96 * sigma[:, 2]):.3f} m)")
        truth.legend(loc="upper right", fontsize=8)
    else:
        truth.text(0.5, 0.5, "no trajectory_sigma.txt", ha="center", transform=truth.transAxes)
    truth.set_ylabel("m")
    truth.set_ylim(bottom=0.0)
    truth.set_title("How far from the truth: 95 % of the poses within", fontsize=10)
    truth.grid(alpha=0.3)
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
        # Where the GNSS was judged bad, a tick under the curves at the nearest pose's distance.
        for kind, fixes in judged.items():
            if len(fixes):
                at = np.clip(np.searchsorted(corrected[:, 0], fixes[:, 0]), 0, len(s) - 1)
                color, _, order = FIX_STYLE[kind]
                dev.scatter(s[at], np.zeros(len(at)), marker="|", color=color, s=60,
                            zorder=order, label=f"{kind} fixes")
        dev.legend(loc="upper right", fontsize=8)
    dev.set_xlabel("distance along the drive (m)")
    dev.set_ylabel("deviation from the GNSS (m)")
    dev.set_title("Deviation from the GNSS (the fit, not the truth)", fontsize=10)
    dev.grid(alpha=0.3)
    fig.suptitle(f"flexcloud: {len(corrected)} poses, {len(cps)} control points; fixes: "
                 f"{len(judged['rejected'])} rejected, {len(judged['down-weighted'])} "
                 f"down-weighted, {len(judged['above threshold'])} above the std-dev threshold",
                 fontsize=10)
    # A fixed layout: tight_layout measured every label again (0.1 s of a city run's plot).
    fig.subplots_adjust(left=0.065, right=0.985, bottom=0.09, top=0.9, wspace=0.15)
    fig.savefig(os.path.join(folder, "report.png"), dpi=110, pil_kwargs={"compress_level": 3})
    return 0


if __name__ == "__main__":
    if len(sys.argv) != 2 or sys.argv[1] in ("-h", "--help"):
        print(__doc__.strip().splitlines()[2])
        sys.exit(0 if len(sys.argv) == 2 else 2)
    if sys.argv[1] != "-":
        sys.exit(main(sys.argv[1]))
    # The folder on standard input: started before the run's files exist, the imports above
    # done while they are made; nothing to draw when none comes.
    folder = sys.stdin.readline().strip()
    sys.exit(main(folder) if folder else 0)
