#!/usr/bin/env python3
"""scripts/screenshot.sh: writes the picture where it is told, refuses to run without a path
(the tracked doc/rviz.png is never overwritten by default), and ends everything it started.

Run by scripts/test.sh (after the build) with the other tests of this folder.
"""
import os
import pathlib
import subprocess
import tempfile
import sys
import unittest

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "scripts" / "screenshot.sh"
sys.path.insert(0, str(ROOT / "scripts"))
from map_drawn import drawn_share  # noqa: E402  (the script's own measure)
STARTED = ("Xvfb", "roslaunch", "rosmaster", "rosout", "nodelet", "rviz")


def processes():
    """pid -> command line of the processes of the kinds the script starts."""
    out = {}
    for entry in pathlib.Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            cmd = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
        except OSError:
            continue
        if any(word in cmd for word in STARTED):
            out[int(entry.name)] = cmd
    return out


class Screenshot(unittest.TestCase):
    def test_without_a_path_it_refuses_and_writes_nothing(self):
        before = (ROOT / "doc" / "rviz.png").stat().st_mtime
        r = subprocess.run([str(SCRIPT)], capture_output=True, text=True, timeout=60)
        self.assertEqual(r.returncode, 2, r.stderr)
        self.assertIn("usage: scripts/screenshot.sh OUTPUT.png", r.stderr)
        self.assertEqual((ROOT / "doc" / "rviz.png").stat().st_mtime, before)

    def test_it_writes_the_picture_given_and_ends_what_it_started(self):
        before = processes()
        with tempfile.TemporaryDirectory(prefix="flexcloud_screenshot_") as tmp:
            out = pathlib.Path(tmp) / "shots" / "rviz.png"
            r = subprocess.run([str(SCRIPT), str(out)], capture_output=True, text=True,
                               timeout=600)
            self.assertEqual(r.returncode, 0, r.stderr[-3000:])
            self.assertEqual(out.read_bytes()[:8], b"\x89PNG\r\n\x1a\n")
            # The map is in the picture: its coloured points cover percents of the view (the
            # trajectories alone, a few thousandths).
            self.assertGreater(drawn_share(out), 0.02)
            self.assertIn("the map covers", r.stderr)
        left = {pid: cmd for pid, cmd in processes().items() if pid not in before}
        self.assertEqual(left, {}, "processes the script left running")

    def test_it_fails_when_rviz_never_draws_the_map(self):
        before = processes()
        with tempfile.TemporaryDirectory(prefix="flexcloud_screenshot_") as tmp:
            out = pathlib.Path(tmp) / "rviz.png"
            # No map covers the whole view: the wait ends in a failure, not a picture.
            env = dict(os.environ, SCREENSHOT_MIN_SHARE="0.99", SCREENSHOT_TIMEOUT="45")
            r = subprocess.run([str(SCRIPT), str(out)], capture_output=True, text=True,
                               timeout=600, env=env)
            self.assertEqual(r.returncode, 1, r.stderr[-3000:])
            self.assertIn("rviz never drew the map: it covers ", r.stderr)
            self.assertFalse(out.exists())
        left = {pid: cmd for pid, cmd in processes().items() if pid not in before}
        self.assertEqual(left, {}, "processes the script left running")


if __name__ == "__main__":
    unittest.main()
