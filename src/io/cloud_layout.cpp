#include "flexcloud/io/cloud_layout.h"

#include <algorithm>
#include <string>
#include <vector>

namespace flexcloud {

pcl::PCLPointField pointField(const std::string& name, std::uint32_t offset,
                              std::uint8_t datatype) {
  pcl::PCLPointField f;
  f.name = name;
  f.offset = offset;
  f.datatype = datatype;
  f.count = 1;
  return f;
}

bool sameFields(const std::vector<pcl::PCLPointField>& a,
                const std::vector<pcl::PCLPointField>& b) {
  return a.size() == b.size() &&
         std::equal(a.begin(), a.end(), b.begin(), [](const auto& x, const auto& y) {
           return x.name == y.name && x.offset == y.offset && x.datatype == y.datatype &&
                  x.count == y.count;
         });
}

XyzLayout xyzLayout(const pcl::PCLPointCloud2& cloud, const std::string& name) {
  return xyzLayout(cloud.fields, cloud.point_step,
                   static_cast<std::size_t>(cloud.width) * cloud.height, cloud.data.size(), name);
}

XyzLayout xyzLayout(const std::vector<pcl::PCLPointField>& fields, std::size_t point_step,
                    std::size_t points, std::size_t data_size, const std::string& name) {
  XyzLayout l;
  l.point_step = point_step;
  l.points = points;
  if (data_size != l.points * l.point_step) {
    throw Error(name + ": data holds " + std::to_string(data_size) + " bytes, but " +
                std::to_string(l.points) + " points of " + std::to_string(l.point_step) +
                " bytes need " + std::to_string(l.points * l.point_step));
  }
  const char* axes[3] = {"x", "y", "z"};
  for (int a = 0; a < 3; ++a) {
    bool found = false;
    for (const auto& f : fields) {
      if (f.name != axes[a]) continue;
      found = true;
      if (f.datatype != pcl::PCLPointField::FLOAT32 && f.datatype != pcl::PCLPointField::FLOAT64) {
        throw Error(name + ": field " + f.name + " is not FLOAT32 or FLOAT64 (type " +
                    std::to_string(f.datatype) + ")");
      }
      l.is_double[a] = f.datatype == pcl::PCLPointField::FLOAT64;
      l.offset[a] = f.offset;
      if (f.offset + (l.is_double[a] ? 8u : 4u) > l.point_step) {
        throw Error(name + ": field " + f.name + " lies outside the point (offset " +
                    std::to_string(f.offset) + ", point step " + std::to_string(l.point_step) +
                    ")");
      }
    }
    if (!found) throw Error(name + ": the cloud has no '" + axes[a] + "' field");
  }
  return l;
}

std::vector<pcl::PCLPointField> withSigmaFields(std::vector<pcl::PCLPointField> fields,
                                                std::size_t point_step, const std::string& name) {
  for (const auto& f : fields) {
    if (f.name == "sigma_h" || f.name == "sigma_v") {
      throw Error(name + ": already holds a field " + f.name +
                  " (georeferenced before?); point_sigma would write it again");
    }
  }
  const auto step = static_cast<std::uint32_t>(point_step);
  fields.push_back(pointField("sigma_h", step, pcl::PCLPointField::FLOAT32));
  fields.push_back(pointField("sigma_v", step + 4, pcl::PCLPointField::FLOAT32));
  return fields;
}

namespace {

std::optional<PointPoseField::Type> poseFieldType(std::uint8_t datatype) {
  using T = PointPoseField::Type;
  switch (datatype) {
    case pcl::PCLPointField::FLOAT64:
      return T::kFloat64;
    case pcl::PCLPointField::INT8:
      return T::kInt8;
    case pcl::PCLPointField::UINT8:
      return T::kUint8;
    case pcl::PCLPointField::INT16:
      return T::kInt16;
    case pcl::PCLPointField::UINT16:
      return T::kUint16;
    case pcl::PCLPointField::INT32:
      return T::kInt32;
    case pcl::PCLPointField::UINT32:
      return T::kUint32;
    default:
      return std::nullopt;
  }
}

PointPoseField poseField(const pcl::PCLPointField& f, PointPoseField::Type type) {
  PointPoseField p;
  p.name = f.name;
  p.type = type;
  p.kind = type == PointPoseField::Type::kFloat64 ? PointPoseField::Kind::kTime
                                                  : PointPoseField::Kind::kIndex;
  p.offset = f.offset;
  return p;
}

}  // namespace

std::optional<PointPoseField> pointPoseField(const std::vector<pcl::PCLPointField>& fields,
                                             const std::string& wanted, const std::string& name) {
  if (wanted == "none") return std::nullopt;
  if (wanted == "auto") {
    for (const char* n : {"time", "timestamp", "gps_time", "t"}) {
      for (const auto& f : fields) {
        if (f.name == n && f.count == 1 && f.datatype == pcl::PCLPointField::FLOAT64)
          return poseField(f, PointPoseField::Type::kFloat64);
      }
    }
    for (const char* n : {"scan_index", "scan_id", "scan", "keyframe"}) {
      for (const auto& f : fields) {
        const auto type = poseFieldType(f.datatype);
        if (f.name == n && f.count == 1 && type && *type != PointPoseField::Type::kFloat64)
          return poseField(f, *type);
      }
    }
    return std::nullopt;
  }
  for (const auto& f : fields) {
    if (f.name != wanted) continue;
    const auto type = poseFieldType(f.datatype);
    if (!type || f.count != 1) {
      throw Error(name + ": map_pose_field '" + wanted +
                  "' is neither float64 (a time) nor an integer (a pose's index): type " +
                  std::to_string(f.datatype) + ", count " + std::to_string(f.count));
    }
    return poseField(f, *type);
  }
  throw Error(name + ": map_pose_field '" + wanted +
              "': no such field (auto: find one; none: move the map by the rubber sheet)");
}

MapMotion mapMotion(const std::vector<pcl::PCLPointField>& fields, const std::string& wanted,
                    const PoseCorrections& corrections,
                    const std::function<std::vector<double>(const PointPoseField&)>& sample,
                    const std::string& name) {
  MapMotion m;
  const std::optional<PointPoseField> field = pointPoseField(fields, wanted, name);
  if (!field) return m;
  const std::string why = corrections.mismatch(*field, sample(*field));
  if (why.empty()) {
    m.rebuild = PoseRebuild{*field, &corrections};
  } else if (wanted == "auto") {
    m.note = name + ": " + why + "; the map is moved by the rubber sheet";
  } else {
    throw Error(name + ": map_pose_field: " + why);
  }
  return m;
}

WarpStats warpCloud(pcl::PCLPointCloud2& cloud, const RubberSheet& sheet, int threads,
                    const std::string& name, const CancelToken& cancel) {
  return warpPoints(cloud.data.data(), xyzLayout(cloud, name), sheet, threads, name, cancel);
}

ErrorStats compareClouds(const pcl::PCLPointCloud2& cloud, const pcl::PCLPointCloud2& truth,
                         const std::function<Eigen::Vector3d(const Eigen::Vector3d&)>& f) {
  const XyzLayout a = xyzLayout(cloud, "map");
  const XyzLayout b = xyzLayout(truth, "truth");
  if (a.points != b.points) {
    throw Error("truth: " + std::to_string(b.points) + " points, the map has " +
                std::to_string(a.points));
  }
  ErrorAccumulator acc;
  comparePoints(cloud.data.data(), a, truth.data.data(), b, a.points, f, acc);
  return acc.stats();
}

}  // namespace flexcloud
