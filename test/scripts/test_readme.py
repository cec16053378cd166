#!/usr/bin/env python3
"""Every command in the README's bash blocks, run as a user types it: from a folder outside the
repository, with the README's placeholder files (drive.bag, /data/...) made from a simulated
drive, a ROS master of its own and a virtual display for rviz. A README command that no test here
runs fails the suite, so the README and this file stay in step.

Run by scripts/test.sh (after the build) as
    /usr/bin/python3 -m xmlrunner discover -s test/scripts -p 'test_*.py'
"""
import os
import pathlib
import re
import shutil
import signal
import subprocess
import tempfile
import time
import unittest

ROOT = pathlib.Path(__file__).resolve().parents[2]
README = ROOT / "README.md"

# Commands the suite does not run, and why. Each is still checked to be a real script.
NOT_RUN = {
    "scripts/test.sh": "the suite itself",
    "scripts/test.sh --quick": "the suite itself",
    "scripts/test.sh --sanitize": "the suite itself",
    "scripts/test.sh --fuzz 60": "the suite itself (it fuzzes for 20 s)",
    "scripts/fuzz.sh 600": "ten minutes per target; the suite fuzzes each for 20 s",
    "scripts/benchmark.sh": "minutes on 10 M points; doc/BENCHMARKS.md holds its figures",
    "scripts/accuracy.sh": "a few minutes; the end-to-end tests assert its targets",
    "scripts/test_platform.sh bullseye": "CI runs it after scripts/test.sh (a chroot, minutes)",
}


def readme_commands():
    """The logical lines of the README's bash blocks, comments and continuations removed."""
    commands = []
    for block in re.findall(r"```bash\n(.*?)```", README.read_text(), re.S):
        for line in block.replace("\\\n", " ").splitlines():
            line = re.sub(r"\s+#.*$", "", line)
            line = re.sub(r"\s+", " ", line).strip()
            if line:
                commands.append(line)
    return commands


def clean_env(**extra):
    """The environment of a new shell: no ROS workspace sourced, Debian's python first."""
    env = {k: v for k, v in os.environ.items()
           if not k.startswith(("ROS_", "CMAKE_PREFIX", "PYTHONPATH", "LD_LIBRARY", "PKG_CONFIG"))}
    env["PATH"] = "/usr/bin:/bin:/usr/sbin:/sbin:" + env.get("PATH", "")
    env.update(extra)
    return env


class Readme(unittest.TestCase):
    ran = set()

    @classmethod
    def setUpClass(cls):
        cls.tmp = pathlib.Path(tempfile.mkdtemp(prefix="flexcloud_readme_"))
        cls.user = cls.tmp / "user"     # where the user types the commands
        cls.data = cls.tmp / "data"     # the README's /data/
        cls.home = cls.tmp / "home"     # the README's ~
        for d in (cls.user, cls.data, cls.home):
            d.mkdir()
        port = 12000 + os.getpid() % 2000
        cls.env = clean_env(ROS_MASTER_URI=f"http://localhost:{port}", HOME=str(cls.home),
                            CCACHE_DIR=os.environ.get("CCACHE_DIR",
                                                      str(pathlib.Path.home() / ".cache/ccache")),
                            ROS_HOME=str(cls.tmp / "ros_home"))
        cls.xvfb = subprocess.Popen(["Xvfb", f":{port % 100 + 100}", "-screen", "0", "1024x768x24"],
                                    stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        cls.env["DISPLAY"] = f":{port % 100 + 100}"
        # A 1 km drive with the topic names of the live example (fixtures, not README commands).
        drive = cls.tmp / "drive"
        out = subprocess.run([str(ROOT / "scripts/env.sh"), "rosrun", "flexcloud", "simulate_drive",
                              "--out", str(drive), "--length", "1000", "--map-points", "50000",
                              "--fix-topic", "/gnss/fix", "--odom-topic", "/slam/odom",
                              "--keyframes"],
                             env=cls.env, capture_output=True, text=True)
        assert out.returncode == 0, out.stdout + out.stderr
        for name, target in [("drive.bag", "drive.bag"), ("slam_map.pcd", "map.pcd"),
                             ("map.pcd", "map.pcd"), ("gnss.txt", "gnss.txt"),
                             ("poses_tum.txt", "slam_trajectory.txt"), ("keyframes", "keyframes")]:
            (cls.user / name).symlink_to(drive / target)
        for name, target in [("drive.bag", "drive.bag"), ("slam_map.pcd", "map.pcd")]:
            (cls.data / name).symlink_to(drive / target)

    @classmethod
    def tearDownClass(cls):
        cls.xvfb.terminate()
        cls.xvfb.wait()
        if not os.environ.get("FLEXCLOUD_KEEP_TMP"):
            shutil.rmtree(cls.tmp, ignore_errors=True)

    # ---- running commands -------------------------------------------------------------------

    def typed(self, command):
        """The command with the README's placeholders pointed at this test's files."""
        self.assertIn(command, readme_commands(), "not a README command")
        Readme.ran.add(command)
        command = command.replace("/data/", f"{self.data}/")
        return re.sub(r"(^|\s)scripts/", lambda m: f"{m.group(1)}{ROOT}/scripts/", command)

    def run_typed(self, command, cwd=None, timeout=600, env=None):
        r = subprocess.run(["bash", "-c", self.typed(command)], cwd=cwd or self.user,
                           env=env or self.env, capture_output=True, text=True, timeout=timeout)
        self.assertEqual(r.returncode, 0, f"{command}\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}")
        return r.stdout + r.stderr

    def start_typed(self, command, env=None, cwd=None):
        """A long-running command (roslaunch) in its own process group."""
        with open(self.tmp / f"bg_{len(Readme.ran)}.log", "w") as log:
            return subprocess.Popen(["bash", "-c", self.typed(command)], cwd=cwd or self.user,
                                    env=env or self.env, stdout=log, stderr=subprocess.STDOUT,
                                    start_new_session=True)

    @staticmethod
    def stop(proc):
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGINT)
            try:
                proc.wait(30)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()

    def ros(self, args, env=None, timeout=15):
        """A ROS command in the repository's workspace (a check of this test, not a README line)."""
        return subprocess.run([str(ROOT / "scripts/env.sh")] + args, env=env or self.env,
                              capture_output=True, text=True, timeout=timeout)

    def wait_for_result(self, env=None, shell_prefix=None, timeout=180):
        """Waits until ~result says a result is published; returns the message text."""
        end = time.time() + timeout
        text = ""
        while time.time() < end:
            try:
                if shell_prefix:
                    r = subprocess.run(["bash", "-c", shell_prefix + "rostopic echo -n 1 /flexcloud/result"],
                                       env=env, capture_output=True, text=True, timeout=10)
                else:
                    r = self.ros(["rostopic", "echo", "-n", "1", "/flexcloud/result"], env=env,
                                 timeout=10)
                text = r.stdout
                if "has_result: True" in text:
                    return text
            except subprocess.TimeoutExpired:
                pass
            time.sleep(1)
        self.fail(f"no result published within {timeout} s; last: {text[-2000:]}")

    # ---- the README, top to bottom ----------------------------------------------------------

    def test_01_demo(self):
        out = self.run_typed("scripts/demo.sh", timeout=900)
        self.assertIn("map vs truth", out)
        # The closing hint plays the drive this run made.
        self.assertRegex(out, r"roslaunch flexcloud demo\.launch drive:=\S*/out/demo/drive")
        self.assertTrue((ROOT / "out/demo/result/report.json").exists())

    def test_02_offline_tool(self):
        for command in [
                "scripts/georeference.sh --bag drive.bag --map slam_map.pcd --out result/",
                "scripts/georeference.sh --gnss gnss.txt --poses poses_tum.txt --map slam_map.pcd --out result/"]:
            shutil.rmtree(self.user / "result", ignore_errors=True)
            out = self.run_typed(command)
            self.assertIn("control points", out)
            for f in ["map_georeferenced.pcd", "report.json", "origin.yaml"]:
                self.assertTrue((self.user / "result" / f).exists(), f"{command}: {f}")
        shutil.rmtree(self.user / "result", ignore_errors=True)
        out = self.run_typed("scripts/georeference.sh --bag drive.bag --map slam_map.pcd "
                             "--out result/ --autoware --projector mgrs --las")
        self.assertIn("control points", out)
        for f in ["autoware/map_projector_info.yaml", "autoware/pointcloud_map_metadata.yaml",
                  "map_georeferenced.las", "trajectories.geojson", "report.png"]:
            self.assertTrue((self.user / "result" / f).exists(), f)
        self.assertIn("projector_type: MGRS",
                      (self.user / "result/autoware/map_projector_info.yaml").read_text())
        shutil.rmtree(self.user / "result", ignore_errors=True)
        out = self.run_typed("scripts/georeference.sh --bag drive.bag --keyframes keyframes/ "
                             "--out result/")
        self.assertIn("points of a keyframe dump rebuilt", out)
        self.assertTrue((self.user / "result/map_georeferenced.pcd").exists())
        out = self.run_typed("scripts/georeference.sh --help")
        self.assertIn("usage: georeference", out)

    def test_03_simulator(self):
        out = self.run_typed(
            "scripts/env.sh rosrun flexcloud simulate_drive --out sim/ --open --map-points 100000 --outage 60:90")
        self.assertIn("open route", out)
        self.assertTrue((self.user / "sim/truth_map.pcd").exists())
        self.assertIn("usage: simulate_drive", self.run_typed("scripts/env.sh rosrun flexcloud simulate_drive --help"))

    def test_04_live(self):
        launch = self.start_typed(
            "scripts/env.sh roslaunch flexcloud georeference.launch fix:=/gnss/fix odom:=/slam/odom "
            "map_file:=/data/slam_map.pcd rviz:=true")
        try:
            self.assertTrue(self.wait_for_service("/flexcloud/georeference"))
            self.run_typed("scripts/env.sh rosbag play -r 10 /data/drive.bag", timeout=120)
            out = self.run_typed('scripts/env.sh rosservice call /flexcloud/georeference '
                                 '"{control_points: 0, stddev_threshold: 0}"')
            self.assertIn("success: True", out)
            out = self.run_typed('scripts/env.sh rosservice call /flexcloud/save '
                                 '"{directory: /data/georeferenced}"')
            self.assertIn("success: True", out)
            self.assertTrue((self.data / "georeferenced/map_georeferenced.pcd").exists())
            out = self.run_typed("scripts/env.sh rostopic echo -n 1 /flexcloud/result")
            self.assertIn("has_result: True", out)
            out = self.run_typed('scripts/env.sh rosservice call /flexcloud/to_ll '
                                 '"{map_point: {x: 10.0, y: 5.0, z: 0.0}}"')
            self.assertIn("success: True", out)
            self.assertRegex(out, r"latitude: 48\.2")
        finally:
            self.stop(launch)

    def wait_for_service(self, name, timeout=60):
        end = time.time() + timeout
        while time.time() < end:
            if self.ros(["rosservice", "list"]).stdout.count(name):
                return True
            time.sleep(1)
        return False

    def test_05_bag(self):
        launch = self.start_typed(
            "scripts/env.sh roslaunch flexcloud georeference.launch bag:=/data/drive.bag "
            "map_file:=/data/slam_map.pcd georeference_on_bag_end:=true rviz:=true")
        try:
            result = self.wait_for_result()
            self.assertIn("success: True", result)
        finally:
            self.stop(launch)

    def test_06_demo_launch(self):
        launch = self.start_typed("scripts/env.sh roslaunch flexcloud demo.launch")
        try:
            self.assertIn("map_points: 1000000", self.wait_for_result())
        finally:
            self.stop(launch)

    def test_07_ros_native_and_install_space(self):
        """The catkin workspace of the README in a HOME of its own, then the install space alone."""
        env = clean_env(HOME=str(self.home), ROS_MASTER_URI=self.env["ROS_MASTER_URI"],
                        ROS_HOME=self.env["ROS_HOME"], CCACHE_DIR=self.env["CCACHE_DIR"],
                        CMAKE_CXX_COMPILER_LAUNCHER="ccache", CMAKE_C_COMPILER_LAUNCHER="ccache",
                        CCACHE_BASEDIR=str(self.home), CCACHE_NOHASHDIR="1")
        ws = self.home / "catkin_ws"
        ws.mkdir(exist_ok=True)
        for name in ["drive.bag", "map.pcd"]:
            (ws / name).symlink_to(self.user / name)
        native = [
            "mkdir -p ~/catkin_ws/src && cd ~/catkin_ws/src && git clone REPOSITORY flexcloud",
            "cd ~/catkin_ws && catkin_make -DCMAKE_BUILD_TYPE=Release -DPYTHON_EXECUTABLE=/usr/bin/python3 && source devel/setup.bash",
            "rosrun flexcloud georeference --bag drive.bag --map map.pcd --out result/"]
        script = " && ".join(self.typed(c).replace("REPOSITORY", str(ROOT)) for c in native)
        r = subprocess.run(["bash", "-c", "set -e; " + script], cwd=self.home, env=env,
                           capture_output=True, text=True, timeout=1800)
        self.assertEqual(r.returncode, 0, r.stdout[-3000:] + r.stderr[-3000:])
        self.assertTrue((ws / "result/report.json").exists())

        build = self.typed("cd ~/catkin_ws && catkin_make install -DCMAKE_BUILD_TYPE=Release -DPYTHON_EXECUTABLE=/usr/bin/python3")
        r = subprocess.run(["bash", "-c", build], cwd=self.home, env=env, capture_output=True,
                           text=True, timeout=1800)
        self.assertEqual(r.returncode, 0, r.stdout[-3000:] + r.stderr[-3000:])
        # Only the install space is left: sources, build and devel space are gone.
        for d in ["src", "build", "devel"]:
            shutil.rmtree(ws / d)
        source = self.typed("source ~/catkin_ws/install/setup.bash") + " && "
        r = subprocess.run(["bash", "-c", source + "rospack find flexcloud && rosrun flexcloud georeference "
                            f"--bag {self.data}/drive.bag --map {self.data}/slam_map.pcd --out {ws}/installed"],
                           cwd=self.home, env=env, capture_output=True, text=True, timeout=300)
        self.assertEqual(r.returncode, 0, r.stdout[-3000:] + r.stderr[-3000:])
        self.assertTrue(r.stdout.startswith(str(ws / "install/share/flexcloud")), r.stdout)
        self.assertTrue((ws / "installed/map_georeferenced.pcd").exists())
        launch_cmd = "roslaunch flexcloud georeference.launch bag:=/data/drive.bag georeference_on_bag_end:=true"
        with open(self.tmp / "install_launch.log", "w") as log:
            launch = subprocess.Popen(["bash", "-c", source + self.typed(launch_cmd)],
                                      cwd=self.home, env=env, stdout=log,
                                      stderr=subprocess.STDOUT, start_new_session=True)
        try:
            result = self.wait_for_result(env=env, shell_prefix=source)
            self.assertIn("success: True", result)
        finally:
            self.stop(launch)

    def test_08_every_executable_and_script_answers_help(self):
        for name in ["georeference", "georeference_node", "simulate_drive", "flexcloud_benchmark"]:
            r = self.ros(["rosrun", "flexcloud", name, "--help"])
            self.assertEqual(r.returncode, 0, f"rosrun flexcloud {name}: {r.stdout}{r.stderr}")
            self.assertIn("usage:", r.stdout, name)
            self.assertNotIn("non-unique", r.stdout + r.stderr, name)
        self.assertIn("usage: scripts/env.sh", self.ros(["--help"]).stdout)
        for command in NOT_RUN:
            script = ROOT / command.split()[0]
            self.assertTrue(os.access(script, os.X_OK), command)
            r = subprocess.run([str(script), "--help"], capture_output=True, text=True, timeout=60,
                               env=self.env, cwd=self.user)
            self.assertEqual(r.returncode, 0, command + r.stderr)

    def test_99_every_readme_command_was_run(self):
        missing = [c for c in readme_commands() if c not in Readme.ran and c not in NOT_RUN]
        self.assertEqual(missing, [], "README commands no test runs")


if __name__ == "__main__":
    unittest.main()
