#pragma once
// The real drives beside the repository (../shared/data/NAME), read by the tests where they are.

#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

namespace flexcloud::test {

/// The folder of real drive `name`: $FLEXCLOUD_DATA_DIR/NAME, else shared/data/NAME beside the
/// repository (found from the real path of its CMakeLists.txt, so a workspace of links to the
/// repository finds it too); empty when neither holds the drive.
inline std::string findRealDrive(const std::string& name) {
  namespace fs = std::filesystem;
  std::vector<fs::path> candidates;
  if (const char* env = std::getenv("FLEXCLOUD_DATA_DIR"))
    candidates.emplace_back(fs::path(env) / name);
  candidates.emplace_back(fs::path(FLEXCLOUD_REPO_DIR).parent_path() / "shared" / "data" / name);
  for (const auto& c : candidates) {
    if (fs::exists(c / "slam_poses_tum.txt") && fs::exists(c / "gnss_local_at_poses.txt")) {
      return c.string();
    }
  }
  return "";
}

/// The folder of drive `name` with a ground truth (poses_tum.txt, gt_tum.txt), as findRealDrive
/// looks for it: e.g. "kitti_lo/07". Empty where it is not found.
inline std::string findTruthDrive(const std::string& name) {
  namespace fs = std::filesystem;
  std::vector<fs::path> candidates;
  if (const char* env = std::getenv("FLEXCLOUD_DATA_DIR"))
    candidates.emplace_back(fs::path(env) / name);
  candidates.emplace_back(fs::path(FLEXCLOUD_REPO_DIR).parent_path() / "shared" / "data" / name);
  for (const auto& c : candidates) {
    if (fs::exists(c / "poses_tum.txt") && fs::exists(c / "gt_tum.txt")) return c.string();
  }
  return "";
}

}  // namespace flexcloud::test
