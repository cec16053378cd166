#!/usr/bin/env python3
"""The launch files' parameters as roslaunch sets them (roslaunch --dump-params, no node started):
a user's config keeps every value the command line does not give, and an argument given on the
command line wins over the config.

Run by scripts/test.sh (after the build) with the other tests of this folder.
"""
import pathlib
import subprocess
import tempfile
import unittest

import yaml

ROOT = pathlib.Path(__file__).resolve().parents[2]

USER_CONFIG = """
enu_frame: world_enu
map_frame: slam_map
odom_type: pose
georeference_on_bag_end: true
bag: /drives/monday.bag
map_file: /drives/monday.pcd
control_points: 77
"""


def dump_params(*args):
    """The parameters roslaunch would set for `georeference.launch ARGS`, by name."""
    r = subprocess.run([str(ROOT / "scripts/env.sh"), "roslaunch", "--dump-params", "flexcloud",
                        "georeference.launch", *args], capture_output=True, text=True, timeout=120)
    if r.returncode != 0:
        raise AssertionError(r.stdout + r.stderr)
    return yaml.safe_load(r.stdout)


class Launch(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory(prefix="flexcloud_launch_")
        cls.config = pathlib.Path(cls.tmp.name) / "my.yaml"
        cls.config.write_text(USER_CONFIG)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_the_users_config_is_not_overwritten_by_argument_defaults(self):
        p = dump_params(f"config:={self.config}")
        want = yaml.safe_load(USER_CONFIG)
        for name, value in want.items():
            self.assertEqual(p[f"/flexcloud/{name}"], value, name)

    def test_arguments_given_win_over_the_config(self):
        p = dump_params(f"config:={self.config}", "enu_frame:=enu2", "odom_type:=path",
                        "georeference_on_bag_end:=false", "bag:=/other.bag")
        self.assertEqual(p["/flexcloud/enu_frame"], "enu2")
        self.assertEqual(p["/flexcloud/odom_type"], "path")
        self.assertIs(p["/flexcloud/georeference_on_bag_end"], False)
        self.assertEqual(p["/flexcloud/bag"], "/other.bag")
        self.assertEqual(p["/flexcloud/map_frame"], "slam_map")

    def test_the_default_config_gives_the_node_its_defaults(self):
        p = dump_params()
        self.assertEqual(p["/flexcloud/enu_frame"], "enu")
        self.assertEqual(p["/flexcloud/odom_type"], "odometry")
        self.assertEqual(p.get("/flexcloud/bag", ""), "")


if __name__ == "__main__":
    unittest.main()
