"""The two checks on the node's threads, each shown to catch what it is there for: clang's
thread-safety analysis rejects a member of GuardedMutex's read without the mutex held
(include/flexcloud/ros/guarded_mutex.h), and scripts/tsan_reports.py counts a race that
ThreadSanitizer reports on flexcloud's code while it leaves the reports inside uninstrumented
libraries out."""
import importlib.util
import pathlib
import subprocess
import tempfile
import unittest

ROOT = pathlib.Path(__file__).resolve().parents[2]
spec = importlib.util.spec_from_file_location("tsan_reports", ROOT / "scripts" / "tsan_reports.py")
tsan_reports = importlib.util.module_from_spec(spec)
spec.loader.exec_module(tsan_reports)
CLANG = "clang++-14"

GUARDED = """
#include "flexcloud/ros/guarded_mutex.h"
#include <string>
struct Node {
  flexcloud::GuardedMutex mutex_;
  std::string bag_ FLEXCLOUD_GUARDED_BY(mutex_);
  std::string locked() { flexcloud::GuardedLock lock(mutex_); return bag_; }
  std::string unlocked() { return READ; }
};
int main() { Node n; return static_cast<int>(n.locked().size() + n.unlocked().size()); }
"""

# One node-like race: a worker writes a parameter under the lock, a service reads it without.
# A relaxed flag (no ordering for ThreadSanitizer) makes the read come first on every run.
RACE = """
#include <atomic>
#include <mutex>
#include <thread>
struct Params { int control_points = 200; double threshold = 0.1; };
std::mutex mutex_;
Params params_;
std::atomic<bool> read_done{false};
int main() {
  std::thread reconfigure([] {
    while (!read_done.load(std::memory_order_relaxed)) std::this_thread::yield();
    std::lock_guard<std::mutex> l(mutex_);
    params_.control_points = 40;
  });
  const Params copy = params_;
  read_done.store(true, std::memory_order_relaxed);
  reconfigure.join();
  return copy.control_points > 1000;
}
"""

# A report of the node's run where both accesses are roscpp's and tf2's own (a serialised
# message freed after a publish): ThreadSanitizer cannot see those libraries' atomics.
LIBRARY_REPORT = """==================
WARNING: ThreadSanitizer: data race (pid=19200)
  Write of size 8 at 0x7b300001dd18 by thread T6 (mutexes: write M0):
    #0 operator delete[](void*) <null> (georeference_node+0xd7e5e)
    #1 boost::checked_array_delete<unsigned char>(unsigned char*) /usr/include/boost/core/checked_delete.hpp:43:5 (libflexcloud_ros.so+0xc0cd8)
    #2 ros::Publisher::publish(boost::function<ros::SerializedMessage ()> const&, ros::SerializedMessage&) const <null> (libroscpp.so.4d+0xcbd8c)
    #3 flexcloud::ResultPublisher::show(flexcloud::NodeResult const&) /work/flexcloud/src/ros/result_publisher.cpp:141:7 (libflexcloud_ros.so+0xbbf96)

  Previous read of size 1 at 0x7b300001dd1f by thread T5 (mutexes: write M1, write M2):
    #0 memcpy <null> (georeference_node+0x619be)
    #1 <null> <null> (libtf2_ros.so.1d+0x50c23)

  Mutex M0 (0x7b4400001da0) created at:
    #0 pthread_mutex_init <null> (georeference_node+0x58f4f)
    #1 flexcloud::GeoreferenceNode::start() /work/flexcloud/src/ros/georeference_node.cpp:56:16 (libflexcloud_ros.so+0xc6134)

SUMMARY: ThreadSanitizer: data race (/work/georeference_node+0xd7e5e) in operator delete[](void*)
==================
"""


def compile_guarded(read, folder):
    source = pathlib.Path(folder, "node.cpp")
    source.write_text(GUARDED.replace("READ", read))
    return subprocess.run([CLANG, "-std=c++17", "-fsyntax-only", "-Wthread-safety",
                           "-Werror=thread-safety", "-I", str(ROOT / "include"), str(source)],
                          capture_output=True, text=True)


class ThreadChecks(unittest.TestCase):
    def test_a_guarded_member_read_without_its_mutex_does_not_compile(self):
        with tempfile.TemporaryDirectory() as folder:
            bad = compile_guarded("bag_", folder)
            self.assertNotEqual(bad.returncode, 0)
            self.assertIn("reading variable 'bag_' requires holding mutex 'mutex_'", bad.stderr)
            good = compile_guarded("locked()", folder)
            self.assertEqual(good.returncode, 0, good.stderr)

    def test_a_race_in_our_code_is_counted_and_library_reports_are_not(self):
        with tempfile.TemporaryDirectory() as folder:
            ours = pathlib.Path(folder, "src", "ros")
            ours.mkdir(parents=True)
            (ours / "race.cpp").write_text(RACE)
            binary = pathlib.Path(folder, "race")
            subprocess.run([CLANG, "-std=c++17", "-g", "-fsanitize=thread", str(ours / "race.cpp"),
                            "-o", str(binary)], check=True)
            reports = pathlib.Path(folder, "reports")
            reports.mkdir()
            subprocess.run([str(binary)], env={"TSAN_OPTIONS": f"log_path={reports}/report"})
            (reports / "report.1").write_text(LIBRARY_REPORT)
            self.assertEqual(tsan_reports.main(str(reports)), 1)
            junit = (reports / "tsan-reports.xml").read_text()
            self.assertEqual(junit.count("<failure"), 1)
            self.assertIn("race.cpp:15", junit)  # the unlocked read of params_
            self.assertIn("1 reports inside uninstrumented libraries ignored", junit)
            (reports / next(p.name for p in reports.glob("report.*") if p.name != "report.1")
             ).unlink()
            self.assertEqual(tsan_reports.main(str(reports)), 0)  # the library's alone


if __name__ == "__main__":
    unittest.main()
