#include "flexcloud/io/keyframes.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "flexcloud/input/trajectory.h"
#include "flexcloud/io/cloud_layout.h"
#include "flexcloud/io/pcd_header.h"
#include "flexcloud/io/pcd_io.h"
#include "flexcloud/io/pcd_stream.h"
#include "flexcloud/io/text_io.h"
#include "flexcloud/uncertainty/point_sigma.h"

namespace flexcloud {
namespace {

namespace fs = std::filesystem;

/// The four numbers of the estimate's row `row` (1-4) at `line`.
Eigen::RowVector4d matrixRow(std::istringstream& in, const std::string& name, int row) {
  std::string line;
  Eigen::RowVector4d r;
  if (!std::getline(in, line))
    throw Error(name + ": estimate: row " + std::to_string(row) + " missing");
  std::istringstream s(line);
  for (int c = 0; c < 4; ++c) {
    if (!(s >> r(c))) {
      throw Error(name + ": estimate: row " + std::to_string(row) + " is not four numbers: '" +
                  line + "'");
    }
  }
  return r;
}

Pose poseOf(double stamp, const Eigen::Matrix4d& m, const std::string& name) {
  const Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
  const double off = (r * r.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (!m.allFinite() || off > 1e-4 || r.determinant() < 0.0 ||
      (m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-9) {
    throw Error(name + ": estimate is not a rigid transform (rotation off by " +
                std::to_string(off) + ")");
  }
  Pose p;
  p.stamp = stamp;
  p.position = m.topRightCorner<3, 1>();
  p.orientation = Eigen::Quaterniond(r).normalized();
  return p;
}

}  // namespace

Pose parseKeyframeData(const std::string& text, const std::string& name) {
  std::istringstream in(text);
  std::string line;
  bool has_stamp = false;
  double stamp = 0.0;
  Eigen::Matrix4d m;
  bool has_estimate = false;
  while (std::getline(in, line)) {
    std::istringstream s(line);
    std::string key;
    s >> key;
    if (key == "stamp") {
      long long sec = 0, nsec = 0;
      if (!(s >> sec >> nsec)) throw Error(name + ": stamp is not SEC NSEC: '" + line + "'");
      stamp = static_cast<double>(sec) + 1e-9 * static_cast<double>(nsec);
      has_stamp = true;
    } else if (key == "estimate") {
      for (int r = 0; r < 4; ++r) m.row(r) = matrixRow(in, name, r + 1);
      has_estimate = true;
    }
  }
  if (!has_stamp) throw Error(name + ": no 'stamp SEC NSEC' line");
  if (!has_estimate) throw Error(name + ": no 'estimate' with its 4x4 pose");
  return poseOf(stamp, m, name);
}

std::string keyframeDataText(const Pose& pose) {
  const Eigen::Matrix4d m = isometryOf(pose).matrix();
  const auto sec = static_cast<long long>(std::floor(pose.stamp));
  const auto nsec = static_cast<long long>(std::llround((pose.stamp - sec) * 1e9));
  std::ostringstream s;
  s.precision(17);
  s << "stamp " << sec << ' ' << nsec << "\nestimate\n"
    << m << "\nodom\n"
    << m << "\naccum_distance -1\n";
  return s.str();
}

std::vector<Keyframe> readKeyframes(const std::string& dir) {
  if (!fs::is_directory(dir)) throw Error(dir + ": not a folder of keyframes");
  std::vector<Keyframe> out;
  for (const auto& e : fs::directory_iterator(dir)) {
    const fs::path data = e.path() / "data", cloud = e.path() / "cloud.pcd";
    if (!e.is_directory() || !fs::exists(data) || !fs::exists(cloud)) continue;
    out.push_back({cloud.string(), parseKeyframeData(readWholeFile(data.string()), data.string())});
  }
  if (out.empty()) {
    throw Error(dir +
                ": no keyframe (a subfolder with data and cloud.pcd, as hdl_graph_slam "
                "saves them)");
  }
  std::sort(out.begin(), out.end(),
            [](const Keyframe& a, const Keyframe& b) { return a.pose.stamp < b.pose.stamp; });
  for (std::size_t i = 1; i < out.size(); ++i) {
    if (out[i].pose.stamp == out[i - 1].pose.stamp) {
      throw Error(dir + ": " + out[i - 1].cloud + " and " + out[i].cloud + " have the same stamp");
    }
  }
  return out;
}

Trajectory keyframePoses(const std::vector<Keyframe>& keyframes) {
  Trajectory t;
  t.reserve(keyframes.size());
  for (const auto& k : keyframes) t.push_back(k.pose);
  return t;
}

void writeKeyframeMap(const std::vector<Keyframe>& keyframes, const PoseCorrections& corrections,
                      const std::string& out, const PointSigmaField* sigmas,
                      const CancelToken& cancel, MapInfo& info) {
  const auto t0 = std::chrono::steady_clock::now();
  const PcdHeader first = readPcdHeader(keyframes.front().cloud);
  const std::vector<pcl::PCLPointField> fields = pclFields(first);
  std::size_t total = 0;
  for (const auto& k : keyframes) {
    const PcdHeader h = readPcdHeader(k.cloud);
    if (h.point_step != first.point_step || !sameFields(pclFields(h), fields)) {
      throw Error(k.cloud + ": its fields differ from those of " + keyframes.front().cloud);
    }
    total += h.points;
  }
  const std::size_t step = first.point_step + (sigmas != nullptr ? kPointSigmaBytes : 0);
  const auto out_fields = sigmas != nullptr
                              ? withSigmaFields(fields, first.point_step, keyframes.front().cloud)
                              : fields;
  PcdChunkWriter writer(out, out_fields, step, static_cast<std::uint32_t>(total), 1);
  std::vector<std::uint8_t> rows;
  for (const auto& k : keyframes) {
    cancel.check(out + ": keyframes");
    pcl::PCLPointCloud2 c = readPcd(k.cloud);
    if (c.point_step != first.point_step) {
      throw Error(k.cloud + ": its points are " + std::to_string(c.point_step) + " bytes, " +
                  keyframes.front().cloud + "'s " + std::to_string(first.point_step));
    }
    XyzLayout layout = xyzLayout(c, k.cloud);
    const std::size_t n = layout.points;
    std::uint8_t* data = c.data.data();  // moved in place, or with sigmas in widened rows
    SigmaSink sink;
    if (sigmas != nullptr) {
      rows.resize(n * step);
      widenPoints(c.data.data(), c.point_step, n, rows.data());
      sink = {sigmas, rows.data() + c.point_step, step};
      data = rows.data();
      layout.point_step = step;
    }
    const WarpStats s =
        rebuildKeyframe(data, layout, isometryOf(k.pose), k.pose.stamp, corrections, sink);
    writer.write(data, n);
    info.warp.merge(s);
  }
  writer.commit();
  info.pose_field = kKeyframeDump;
  info.warp_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace flexcloud
