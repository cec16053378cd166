// PlotJob with small Python scripts in place of the package's plot script: the folder handed
// over on standard input, the reasons a picture was not drawn, and a script that is gone before
// it is told the folder (no SIGPIPE for the caller).
#include <gtest/gtest.h>
#include <signal.h>

#include <cerrno>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include "flexcloud/io/report_plot.h"

namespace flexcloud {
namespace {

namespace fs = std::filesystem;

bool hasText(const fs::path& p) {
  std::error_code ec;
  return fs::exists(p, ec) && fs::file_size(p, ec) > 0;
}

/// A fresh folder and a script in it with `body` (Python).
struct Scratch {
  explicit Scratch(const std::string& name, const std::string& body)
      : dir(fs::path(testing::TempDir()) / ("flexcloud_plot_" + name)) {
    fs::remove_all(dir);
    fs::create_directories(dir);
    std::ofstream(script()) << "import os, sys\n" << body;
  }
  std::string script() const { return (dir / "plot.py").string(); }
  fs::path dir;
};

TEST(PlotJob, TheFolderComesOnStandardInput) {
  const Scratch s("draws", R"(assert sys.argv[1] == "-"
folder = sys.stdin.readline().strip()
open(os.path.join(folder, "report.png"), "w").write("picture")
)");
  PlotJob job(s.script());
  job.draw(s.dir.string());
  EXPECT_EQ(job.finish(), "");
  EXPECT_TRUE(fs::exists(s.dir / "report.png"));
}

TEST(PlotJob, AFailedScriptSaysWhy) {
  const Scratch s("fails", R"(sys.stdin.readline()
print("warming up", file=sys.stderr)
raise ValueError("the trajectories differ in length")
)");
  PlotJob job(s.script());
  job.draw(s.dir.string());
  EXPECT_EQ(job.finish(),
            "report.png skipped: the plot script failed: ValueError: the trajectories differ in "
            "length");
}

TEST(PlotJob, AScriptGoneBeforeTheFolderIsToldCostsNoSignal) {
  // It closes its input and exits 3 (matplotlib missing) before the folder is written to it.
  const Scratch s("gone", R"(os.close(0)
open(os.path.join(os.path.dirname(sys.argv[0]), "closed"), "w").close()
sys.exit(3)
)");
  PlotJob job(s.script());
  for (int i = 0; i < 500 && !fs::exists(s.dir / "closed"); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_TRUE(fs::exists(s.dir / "closed"));
  job.draw(s.dir.string());  // a write into a pipe without a reader: EPIPE, not SIGPIPE
  EXPECT_EQ(job.finish(), "report.png skipped: python3-matplotlib is not installed");
}

TEST(PlotJob, NoFolderNoPicture) {
  const Scratch s("unused", R"(sys.exit(0 if sys.stdin.readline() == "" else 1)
)");
  PlotJob job(s.script());
  EXPECT_EQ(job.finish(), "report.png skipped: the plot script was given no folder");
  EXPECT_EQ(PlotJob("").finish(), "report.png skipped: the plot script was not found");
  EXPECT_EQ(PlotJob((s.dir / "absent.py").string()).finish(),
            "report.png skipped: " + (s.dir / "absent.py").string() + " does not exist");
}

TEST(PlotJob, AnUnfinishedJobIsStoppedWithItsOwner) {
  const Scratch s("stopped", R"(import time
open(os.path.join(os.path.dirname(sys.argv[0]), "pid"), "w").write(str(os.getpid()))
time.sleep(600)
)");
  pid_t pid = 0;
  {
    PlotJob job(s.script());
    for (int i = 0; i < 500 && !hasText(s.dir / "pid"); ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  }
  std::ifstream(s.dir / "pid") >> pid;
  ASSERT_GT(pid, 0);
  EXPECT_NE(kill(pid, 0), 0);  // stopped and waited for: no such process left
  EXPECT_EQ(errno, ESRCH);
}

}  // namespace
}  // namespace flexcloud
