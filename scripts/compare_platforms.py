#!/usr/bin/env python3
"""Holds the offline tool's outputs of two builds of flexcloud (this machine's and another
platform's) against each other: the simulated drive and the result without the fusion to the
last written digit, the defaults' trajectories within a bound (a different Ceres may stop its
solves a few iterations apart). Writes a JUnit file; prints one line per comparison.

    compare_platforms.py HERE THERE RESULT.xml [BOUND_M]
"""
import pathlib
import sys
import xml.sax.saxutils as x


def same_bytes(a, b):
    return a.read_bytes() == b.read_bytes()


def largest_difference(a, b):
    """The largest difference of the numbers in two TUM files of the same rows (m or s)."""
    rows_a = [l.split() for l in a.read_text().splitlines() if l and not l.startswith("#")]
    rows_b = [l.split() for l in b.read_text().splitlines() if l and not l.startswith("#")]
    if len(rows_a) != len(rows_b):
        return float("inf")
    return max((abs(float(p) - float(q)) for ra, rb in zip(rows_a, rows_b)
                for p, q in zip(ra[1:4], rb[1:4])), default=0.0)


def main():
    here, there, out = map(pathlib.Path, sys.argv[1:4])
    bound = float(sys.argv[4]) if len(sys.argv) > 4 else 0.001
    cases = []
    for name in ("drive/gnss.txt", "drive/slam_trajectory.txt", "drive/map.pcd",
                 "fusion_false/trajectory_rubbersheet.txt", "fusion_false/map_georeferenced.pcd"):
        ok = (here / name).exists() and (there / name).exists() and same_bytes(here / name,
                                                                               there / name)
        cases.append((f"same digits: {name}", ok, "identical" if ok else "differ"))
    for name in ("defaults/trajectory_fused.txt", "defaults/trajectory_rubbersheet.txt"):
        d = (largest_difference(here / name, there / name)
             if (here / name).exists() and (there / name).exists() else float("inf"))
        cases.append((f"within {bound} m: {name}", d <= bound, f"largest difference {d:.6f} m"))
    body = ""
    for name, ok, what in cases:
        print(f"[platform] {name}: {what}")
        fail = "" if ok else f'<failure message="{x.escape(what, {chr(34): "&quot;"})}"/>'
        body += f'<testcase classname="platform_outputs" name="{x.escape(name, {chr(34): "&quot;"})}">{fail}</testcase>'
    out.write_text(f'<testsuite name="platform_outputs" tests="{len(cases)}">{body}</testsuite>\n')


if __name__ == "__main__":
    main()
