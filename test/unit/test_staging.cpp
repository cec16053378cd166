// The staging folder of a run's outputs: what a killed run leaves is removed by the next one, a
// live run's is not, and a committed folder holds one run's outputs and the user's own files.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <fstream>

#include "flexcloud/types.h"
#include "staging.h"
#include "test_util.h"

namespace flexcloud {
namespace {

namespace fs = std::filesystem;

std::vector<std::string> stagingFolders(const fs::path& dir) {
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string n = e.path().filename().string();
    if (n.rfind(".flexcloud-staging-", 0) == 0) out.push_back(n);
  }
  return out;
}

std::string readAll(const fs::path& p) {
  std::ifstream in(p);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// A child stages a file and is killed (SIGKILL: no destructor runs); the next run's staging
/// removes what it left, while the staging folder of a run still alive stays.
TEST(Staging, AKilledRunsFolderGoesAndALiveRunsStays) {
  const fs::path dir = test::tempFolder("staging_killed");
  const pid_t child = ::fork();
  if (child == 0) {
    Staging s(dir.string());
    std::ofstream(s.path("map_georeferenced.pcd")) << "half a map";
    ::raise(SIGKILL);
    ::_exit(0);
  }
  int status = 0;
  ::waitpid(child, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status));
  ASSERT_EQ(stagingFolders(dir).size(), 1u);  // left behind by the killed child

  Staging live(dir.string());  // removes the child's, keeps its own
  const auto left = stagingFolders(dir);
  ASSERT_EQ(left.size(), 1u);
  EXPECT_EQ((dir / left[0]).string(), live.folder());
  EXPECT_EQ(removeAbandonedStaging(dir.string()), 0);  // held by this live run: kept
  EXPECT_TRUE(fs::exists(live.folder()));
}

/// A folder of an earlier version (no lock file) goes when the process its name holds is gone.
TEST(Staging, AnUnlockedFolderOfADeadProcessGoes) {
  const fs::path dir = test::tempFolder("staging_unlocked");
  const pid_t child = ::fork();
  if (child == 0) ::_exit(0);
  ::waitpid(child, nullptr, 0);
  fs::create_directories(dir / (".flexcloud-staging-" + std::to_string(child)));
  std::ofstream(dir / (".flexcloud-staging-" + std::to_string(child)) / "report.json") << "{}";
  fs::create_directories(dir / (".flexcloud-staging-" + std::to_string(::getpid())));
  EXPECT_EQ(removeAbandonedStaging(dir.string()), 1);  // the dead one; this process lives
  EXPECT_EQ(stagingFolders(dir).size(), 1u);
}

/// After a commit the folder holds this run's outputs, none of an earlier run's that this run
/// did not write, and every file the user put there.
TEST(Staging, CommitLeavesOneRunsOutputsAndTheUsersFiles) {
  const fs::path dir = test::tempFolder("staging_commit");
  for (const char* f : {"map_georeferenced.pcd", "report.json", "origin.yaml", "notes.txt"}) {
    std::ofstream(dir / f) << "earlier";
  }
  fs::create_directories(dir / "autoware");
  const std::vector<std::string> outputs = {"map_georeferenced.pcd", "autoware", "origin.yaml",
                                            "report.json"};
  {
    Staging s(dir.string());
    std::ofstream(s.path("origin.yaml")) << "now";
    std::ofstream(s.path("report.json")) << "now";
    s.commit("report.json", outputs);
  }
  EXPECT_FALSE(fs::exists(dir / "map_georeferenced.pcd"));
  EXPECT_FALSE(fs::exists(dir / "autoware"));
  EXPECT_EQ(readAll(dir / "origin.yaml"), "now");
  EXPECT_EQ(readAll(dir / "report.json"), "now");
  EXPECT_EQ(readAll(dir / "notes.txt"), "earlier");
  EXPECT_TRUE(stagingFolders(dir).empty());
}

/// Without a commit the folder keeps the earlier run's files, and a folder the run made goes.
TEST(Staging, NoCommitKeepsTheEarlierRun) {
  const fs::path dir = test::tempFolder("staging_none");
  std::ofstream(dir / "report.json") << "earlier";
  {
    Staging s(dir.string());
    std::ofstream(s.path("report.json")) << "now";
  }
  EXPECT_EQ(readAll(dir / "report.json"), "earlier");
  EXPECT_TRUE(stagingFolders(dir).empty());
  const fs::path made = dir / "new";
  { Staging s(made.string()); }
  EXPECT_FALSE(fs::exists(made));
}

/// Errors name the output folder the user gave, never the staging folder.
TEST(Staging, MessagesNameTheOutputFolder) {
  const fs::path dir = test::tempFolder("staging_message");
  Staging s(dir.string());
  const std::string staged = s.path("report.json");
  EXPECT_EQ(s.userMessage(staged + ": write failed (disk full?)"),
            (dir / "report.json").string() + ": write failed (disk full?)");
}

}  // namespace
}  // namespace flexcloud
