#pragma once
// The real drives beside the repository (../shared/data/NAME), read by the tests where they are.

#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

namespace flexcloud::test {

/// The folder of drive `name` holding files `a` and `b`: $FLEXCLOUD_DATA_DIR/NAME, else
/// shared/data/NAME beside the repository (found from the real path of its CMakeLists.txt, so a
/// workspace of links to the repository finds it too); empty when neither holds them.
inline std::string findDrive(const std::string& name, const char* a, const char* b) {
  namespace fs = std::filesystem;
  std::vector<fs::path> candidates;
  if (const char* env = std::getenv("FLEXCLOUD_DATA_DIR"))
    candidates.emplace_back(fs::path(env) / name);
  candidates.emplace_back(fs::path(FLEXCLOUD_REPO_DIR).parent_path() / "shared" / "data" / name);
  for (const auto& c : candidates) {
    if (fs::exists(c / a) && fs::exists(c / b)) return c.string();
  }
  return "";
}

/// The folder of real drive `name` (slam_poses_tum.txt, gnss_local_at_poses.txt).
inline std::string findRealDrive(const std::string& name) {
  return findDrive(name, "slam_poses_tum.txt", "gnss_local_at_poses.txt");
}

/// The folder of drive `name` with a ground truth (poses_tum.txt, gt_tum.txt), e.g. "kitti_lo/07".
inline std::string findTruthDrive(const std::string& name) {
  return findDrive(name, "poses_tum.txt", "gt_tum.txt");
}

/// The folders of the drives `names` of `family` (e.g. "kitti_lo") that are there; empty where
/// none is (the caller skips, saying where it looked: SKIP_WITHOUT_DRIVES).
inline std::vector<std::string> findTruthDrives(const std::string& family,
                                                const std::vector<std::string>& names) {
  std::vector<std::string> out;
  for (const auto& n : names) {
    const std::string dir = findTruthDrive(family + "/" + n);
    if (!dir.empty()) out.push_back(dir);
  }
  return out;
}

}  // namespace flexcloud::test

/// Skips the test where `dirs` (findTruthDrives()) is empty, naming the family looked for.
#define SKIP_WITHOUT_DRIVES(dirs, family)                                          \
  if ((dirs).empty()) {                                                            \
    GTEST_SKIP() << family << " not found (../shared/data/" << family              \
                 << " beside the repository, or set FLEXCLOUD_DATA_DIR); skipped"; \
  }
