#include "flexcloud/warp/pose_rebuild.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>

#include "flexcloud/input/trajectory.h"
#include "flexcloud/uncertainty/point_sigma.h"
#include "parallel.h"

namespace flexcloud {

namespace {

template <typename T>
double readAs(const std::uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return static_cast<double>(v);
}

using Matrix34 = Eigen::Matrix<double, 3, 4>;

Matrix34 matrixOf(const Eigen::Isometry3d& t) { return t.matrix().topRows<3>(); }

/// The pose between a and b at fraction w: positions blended, orientations slerped.
Eigen::Isometry3d between(const Pose& a, const Pose& b, double w) {
  return isometryOf(
      {0.0, a.position + w * (b.position - a.position), a.orientation.slerp(w, b.orientation)});
}

std::string range(const std::vector<double>& values) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (double v : values) {
    if (!std::isfinite(v)) continue;
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  char buf[96];
  std::snprintf(buf, sizeof(buf), "%.3f to %.3f", lo, hi);
  return buf;
}

constexpr float kNaNf = std::numeric_limits<float>::quiet_NaN();

}  // namespace

double PointPoseField::read(const std::uint8_t* point) const {
  const std::uint8_t* p = point + offset;
  switch (type) {
    case Type::kFloat64:
      return readAs<double>(p);
    case Type::kInt8:
      return readAs<std::int8_t>(p);
    case Type::kUint8:
      return readAs<std::uint8_t>(p);
    case Type::kInt16:
      return readAs<std::int16_t>(p);
    case Type::kUint16:
      return readAs<std::uint16_t>(p);
    case Type::kInt32:
      return readAs<std::int32_t>(p);
    case Type::kUint32:
      return readAs<std::uint32_t>(p);
  }
  return std::numeric_limits<double>::quiet_NaN();
}

PoseCorrections::PoseCorrections(const Trajectory& slam, const Trajectory& result,
                                 const Eigen::Isometry3d& rigid)
    : rigid_(rigid) {
  if (slam.empty() || slam.size() != result.size()) {
    throw Error("rebuild: " + std::to_string(result.size()) + " result poses for " +
                std::to_string(slam.size()) + " SLAM poses");
  }
  stamps_.reserve(slam.size());
  corrections_.reserve(slam.size());
  for (std::size_t i = 0; i < slam.size(); ++i) {
    if (i > 0 && !(slam[i].stamp > slam[i - 1].stamp)) {
      throw Error("rebuild: the SLAM's stamps do not increase at pose " + std::to_string(i));
    }
    stamps_.push_back(slam[i].stamp);
    corrections_.push_back(matrixOf(isometryOf(result[i]) * isometryOf(slam[i]).inverse()));
    if (i > 0) {
      halfway_.push_back(matrixOf(between(result[i - 1], result[i], 0.5) *
                                  between(slam[i - 1], slam[i], 0.5).inverse()));
    }
  }
  // Buckets as many as the poses over their span, each with the interval its start lies in.
  const std::size_t n = stamps_.size();
  const double span = stamps_.back() - stamps_.front();
  inv_bucket_ = span > 0.0 ? static_cast<double>(n) / span : 0.0;
  bucket_first_.resize(n + 1);
  std::size_t k = 0;
  for (std::size_t b = 0; b <= n; ++b) {
    const double t = stamps_.front() + static_cast<double>(b) / std::max(inv_bucket_, 1e-300);
    while (k + 2 < n && stamps_[k + 1] <= t) ++k;
    bucket_first_[b] = k;
  }
}

bool PoseCorrections::atIndex(double i, Matrix34& out) const {
  if (!(i >= 0.0) || i >= static_cast<double>(corrections_.size())) return false;
  out = corrections_[static_cast<std::size_t>(i)];
  return true;
}

bool PoseCorrections::atTime(double t, std::size_t& hint, Matrix34& out) const {
  const std::size_t n = stamps_.size();
  if (!std::isfinite(t) || t < stamps_.front() - kReach || t > stamps_.back() + kReach) {
    return false;
  }
  if (t <= stamps_.front() || n == 1) {
    out = corrections_.front();
    return true;
  }
  if (t >= stamps_.back()) {
    out = corrections_.back();
    return true;
  }
  if (hint + 1 >= n || t < stamps_[hint] || t > stamps_[hint + 1]) {
    const auto b = std::min(bucket_first_.size() - 1,
                            static_cast<std::size_t>((t - stamps_.front()) * inv_bucket_));
    hint = bucket_first_[b];
    while (hint + 2 < n && stamps_[hint + 1] < t) ++hint;
  }
  // Through the correction at both poses and halfway: quadratic in w, as the exact one is to
  // within the cube of the correction's turn between the poses.
  const double w = (t - stamps_[hint]) / (stamps_[hint + 1] - stamps_[hint]);
  out = ((1.0 - w) * (1.0 - 2.0 * w)) * corrections_[hint] +
        (4.0 * w * (1.0 - w)) * halfway_[hint] + (w * (2.0 * w - 1.0)) * corrections_[hint + 1];
  return true;
}

int PoseCorrections::poseAt(double t, std::size_t hint) const {
  const std::size_t n = stamps_.size();
  if (n == 1 || t <= stamps_.front()) return 0;
  if (t >= stamps_.back() || hint + 1 >= n) return static_cast<int>(n - 1);
  return static_cast<int>(t - stamps_[hint] > stamps_[hint + 1] - t ? hint + 1 : hint);
}

std::string PoseCorrections::mismatch(const PointPoseField& field,
                                      const std::vector<double>& values) const {
  std::size_t finite = 0, named = 0;
  std::size_t hint = 0;
  Matrix34 m;
  for (double v : values) {
    if (!std::isfinite(v)) continue;
    ++finite;
    const bool ok = field.kind == PointPoseField::Kind::kTime ? atTime(v, hint, m) : atIndex(v, m);
    named += ok ? 1 : 0;
  }
  if (finite == 0) return "field '" + field.name + "' holds no finite value";
  if (10 * named >= 9 * finite) return "";
  const std::string held = "field '" + field.name + "' holds " + range(values) + "; ";
  if (field.kind == PointPoseField::Kind::kIndex) {
    return held + "the trajectory has " + std::to_string(size()) + " poses";
  }
  char buf[160];
  std::snprintf(buf, sizeof(buf), "the trajectory's stamps run from %.3f to %.3f s",
                stamps_.front(), stamps_.back());
  return held + buf + ": not the SLAM's clock";
}

std::vector<double> fieldValues(const std::uint8_t* data, std::size_t step, std::size_t points,
                                const PointPoseField& field, std::size_t max) {
  std::vector<double> values;
  const std::size_t stride = std::max<std::size_t>(1, points / std::max<std::size_t>(1, max));
  for (std::size_t i = 0; i < points; i += stride) values.push_back(field.read(data + i * step));
  return values;
}

namespace {

/// One thread's share of the points: the correction of the last point's pose is kept (a scan's
/// points share their pose, or their time to half a millisecond).
class Rebuilder {
 public:
  Rebuilder(const XyzLayout& layout, const PoseRebuild& rebuild, const SigmaSink& sigmas)
      : layout_(layout),
        rebuild_(rebuild),
        sigmas_(sigmas),
        batch_(sigmas.field != nullptr
                   ? std::make_unique<PointSigmaBatch>(sigmas, PointSigmaBatch::Moved::kWithPose)
                   : nullptr) {}

  void run(std::uint8_t* data, std::size_t begin, std::size_t end, const CancelToken& cancel,
           WarpStats& s) {
    for (std::size_t i = begin; i < end; ++i) {
      if (((i - begin) & 0xFFFF) == 0 && cancel.cancelled()) return;
      std::uint8_t* pt = data + i * layout_.point_step;
      const Eigen::Vector3d p = layout_.get(pt);
      ++s.points;
      if (!p.allFinite()) {
        ++s.non_finite;
        sigmas_.write(i, kNaNf, kNaNf);
        continue;
      }
      if (!lookUp(rebuild_.field.read(pt))) ++s.outside;
      const Eigen::Vector3d q = m_.leftCols<3>() * p + m_.col(3);
      layout_.set(pt, q);
      if (batch_) batch_->add(q, pose_, i);
    }
    if (batch_) batch_->flush();
  }

 private:
  /// Sets m_ to the correction the value names and pose_ to its pose (rigid and kNoPose where
  /// it names none); false there.
  bool lookUp(double v) {
    const bool time = rebuild_.field.kind == PointPoseField::Kind::kTime;
    const double key = time ? std::round(v * 2000.0) : v;
    if (has_key_ && key == key_) return named_;
    const PoseCorrections& c = *rebuild_.corrections;
    named_ = time ? c.atTime(key / 2000.0, hint_, m_) : c.atIndex(v, m_);
    if (batch_) {
      pose_ = !named_ ? PointSigmaField::kNoPose
                      : (time ? c.poseAt(key / 2000.0, hint_) : static_cast<int>(v));
    }
    if (!named_) m_ = c.rigid().matrix().topRows<3>();
    has_key_ = std::isfinite(key);
    key_ = key;
    return named_;
  }

  const XyzLayout& layout_;
  const PoseRebuild& rebuild_;
  const SigmaSink& sigmas_;
  /// The sigmas, a batch at a time (point_sigma.h), as the rigid move of each point's pose.
  std::unique_ptr<PointSigmaBatch> batch_;
  Matrix34 m_ = Matrix34::Zero();
  int pose_ = PointSigmaField::kNoPose;
  bool has_key_ = false, named_ = false;
  double key_ = 0.0;
  std::size_t hint_ = 0;
};

}  // namespace

WarpStats rebuildPoints(std::uint8_t* data, const XyzLayout& layout, const PoseRebuild& rebuild,
                        int threads, const std::string& name, const CancelToken& cancel,
                        const SigmaSink& sigmas) {
  if (rebuild.corrections == nullptr) throw Error(name + ": rebuild: no pose corrections");
  const std::size_t n = layout.points;
  WarpStats total;
  total.sample = samplePoints(data, layout);
  const std::size_t parts = pointRanges(n, threads);
  std::vector<WarpStats> part(parts);
  parallelRanges(n, parts, threads, [&](std::size_t k, std::size_t begin, std::size_t end) {
    Rebuilder(layout, rebuild, sigmas).run(data, begin, end, cancel, part[k]);
  });
  cancel.check(name + ": rebuild");
  for (const auto& s : part) total.merge(s);
  return total;
}

WarpStats rebuildKeyframe(std::uint8_t* data, const XyzLayout& layout,
                          const Eigen::Isometry3d& pose, double stamp,
                          const PoseCorrections& corrections, const SigmaSink& sigmas) {
  WarpStats s;
  std::size_t hint = 0;
  Matrix34 c;
  const bool named = corrections.atTime(stamp, hint, c);
  if (!named) c = corrections.rigid().matrix().topRows<3>();
  const int own = named ? corrections.poseAt(stamp, hint) : PointSigmaField::kNoPose;
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topRows<3>() = c;
  const Matrix34 moved = (m * pose.matrix()).topRows<3>();
  std::unique_ptr<PointSigmaBatch> batch;
  if (sigmas.field != nullptr) {
    batch = std::make_unique<PointSigmaBatch>(sigmas, PointSigmaBatch::Moved::kWithPose);
  }
  const std::size_t n = layout.points;
  const std::size_t stride = std::max<std::size_t>(1, n / 16);
  for (std::size_t i = 0; i < n; ++i) {
    std::uint8_t* pt = data + i * layout.point_step;
    const Eigen::Vector3d p = layout.get(pt);
    ++s.points;
    if (!p.allFinite()) {
      ++s.non_finite;
      sigmas.write(i, kNaNf, kNaNf);
      continue;
    }
    if (i % stride == 0) s.sample.push_back(pose * p);
    const Eigen::Vector3d q = moved.leftCols<3>() * p + moved.col(3);
    layout.set(pt, q);
    if (!named) ++s.outside;
    if (batch) batch->add(q, own, i);
  }
  return s;
}

}  // namespace flexcloud
