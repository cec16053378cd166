#!/usr/bin/env python3
"""What a fresh Debian 12 machine needs comes from scripts/deps.txt: every ROS command the
README and the scripts use is in a package deps.txt names, every other program they call is in
Debian's essential set or pulled in by a listed package; and the C++ sources follow
.clang-format."""
import functools
import pathlib
import re
import shutil
import subprocess
import unittest

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCRIPTS = sorted(ROOT.glob("scripts/*.sh")) + [ROOT / ".ci/run"]
# Tools of ROS 1 (and catkin): their package must be named in deps.txt itself.
ROS_TOOLS = {"rosrun", "roslaunch", "rosservice", "rostopic", "rosbag", "rosparam", "rosnode",
             "roscore", "rostest", "rospack", "catkin_make", "catkin_test_results",
             "catkin_find", "rviz", "rosmsg", "rossrv"}


def listed():
    text = (ROOT / "scripts/deps.txt").read_text()
    return set(re.sub(r"#.*", "", text).split())


def readme_code():
    return "\n".join(re.findall(r"```bash\n(.*?)```", (ROOT / "README.md").read_text(), re.S))


WRAPPERS = {"exec", "sudo", "env", "time", "nohup", "in_workspace", "command", "!", "then", "do",
            "else", "if", "while", "until", "{"}


def commands(text):
    """The words in command position: at the start of each pipeline segment, past variable
    assignments and wrappers (exec, env, in_workspace, scripts/env.sh ...). Comments and
    here-documents are left out."""
    text = re.sub(r"<<'?(\w+)'?\n.*?\n\1\n", "\n", text, flags=re.S)
    found = set()
    for line in text.splitlines():
        line = re.sub(r"(^|\s)#.*$", "", line)
        for segment in re.split(r"\|\||&&|[|;(`]|\$\(", line):
            tokens = segment.split()
            while tokens and (tokens[0] in WRAPPERS or re.match(r"^\w+=", tokens[0])
                              or tokens[0].endswith("env.sh")):
                tokens.pop(0)
            if tokens and re.match(r"^[A-Za-z][\w.+-]*$", tokens[0]):
                found.add(tokens[0])
    return found


@functools.lru_cache(None)
def package_of(path):
    out = subprocess.run(["dpkg", "-S", str(pathlib.Path(path).resolve())], capture_output=True,
                         text=True)
    if out.returncode != 0:
        out = subprocess.run(["dpkg", "-S", path], capture_output=True, text=True)
    return out.stdout.split(":")[0].split(",")[0].strip() if out.returncode == 0 else None


@functools.lru_cache(None)
def closure():
    """Every package that installing deps.txt brings (Depends and Pre-Depends, recursively)."""
    out = subprocess.run(["apt-cache", "depends", "--recurse", "--no-recommends", "--no-suggests",
                          "--no-conflicts", "--no-breaks", "--no-replaces", "--no-enhances"]
                         + sorted(listed()), capture_output=True, text=True)
    return {line.strip().split(":")[0] for line in out.stdout.splitlines()
            if not line.startswith(" ")} | {
        line.split(":", 1)[1].strip().strip("<>").split(":")[0]
        for line in out.stdout.splitlines() if "Depends:" in line}


@functools.lru_cache(None)
def essential(pkg):
    out = subprocess.run(["dpkg-query", "-W", "-f=${Essential} ${Priority}", pkg],
                         capture_output=True, text=True)
    return out.stdout.startswith("yes") or "required" in out.stdout


class Packaging(unittest.TestCase):
    def programs(self):
        """(word, path, where) for every word of the README's commands and the scripts that is
        a program on this machine."""
        found = []
        for where, text in [("README", readme_code())] + [(p.name, p.read_text()) for p in SCRIPTS]:
            for w in sorted(commands(text)):
                path = shutil.which(w, path="/usr/bin:/bin:/usr/sbin:/sbin")
                if path:
                    found.append((w, path, where))
        return found

    def test_ros_commands_come_from_listed_packages(self):
        names = listed()
        seen = set()
        for w, path, where in self.programs():
            if w not in ROS_TOOLS:
                continue
            seen.add(w)
            pkg = package_of(path)
            self.assertIsNotNone(pkg, f"{w} ({where}) belongs to no Debian package")
            self.assertIn(pkg, names, f"{w} ({where}) comes from {pkg}, which scripts/deps.txt "
                                      f"does not list")
        self.assertTrue({"rosrun", "roslaunch", "rosservice", "catkin_make"} <= seen, seen)

    def test_other_programs_are_essential_or_pulled_in(self):
        names = listed()
        for w, path, where in self.programs():
            if w in ROS_TOOLS:
                continue
            pkg = package_of(path)
            if pkg is None:
                continue  # e.g. a link made by update-alternatives; its target is checked below
            self.assertTrue(pkg in names or essential(pkg) or pkg in closure(),
                            f"{w} ({where}) comes from {pkg}: neither listed, essential nor "
                            f"pulled in by a listed package")

    def test_sources_follow_clang_format(self):
        files = [str(p) for d in ["include", "src", "test", "fuzz"]
                 for p in sorted((ROOT / d).rglob("*")) if p.suffix in (".h", ".cpp")]
        out = subprocess.run(["clang-format", "--dry-run", "--Werror", "--style=file"] + files,
                             capture_output=True, text=True, cwd=ROOT)
        offending = sorted(set(re.findall(r"^(\S+?):\d+:\d+: error", out.stderr, re.M)))
        self.assertEqual(out.returncode, 0, f"{len(offending)} files need clang-format -i: "
                                            + " ".join(offending))

    def test_catkin_lint_is_clean(self):
        # -W1: errors and warnings; what CMakeLists.txt ignores, it says why.
        out = subprocess.run(["catkin_lint", "-q", "-W1", str(ROOT)], capture_output=True,
                             text=True)
        self.assertEqual((out.returncode, out.stdout.strip()), (0, ""), out.stdout + out.stderr)

    def test_package_xml_has_no_key_rosdep_lacks(self):
        # python3-xmlrunner (the scripts' test runner) is no rosdep key: deps.txt lists it.
        self.assertNotIn("xmlrunner", (ROOT / "package.xml").read_text())


if __name__ == "__main__":
    unittest.main()
