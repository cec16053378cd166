#include "flexcloud/uncertainty/point_sigma.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

namespace flexcloud {
namespace {

constexpr int kMaxCells = 512;      // cells a side at most: 5 MB of cells
constexpr double kMinCell = 2.0;    // m
constexpr double kPadding = 100.0;  // m around the poses, where most of a map lies
// A tetrahedron's transform may stretch this many times its edges' largest relative change
// (shear changes no edge's length as much as it moves the points between them).
constexpr double kShear = 3.0;

double strainOf(const Affine34& a) {
  const Eigen::Vector3d s = Eigen::JacobiSVD<Eigen::Matrix3d>(a.leftCols<3>()).singularValues();
  return std::max(std::abs(s(0) - 1.0), std::abs(s(2) - 1.0));
}

/// The strain of every tetrahedron: how far its transform is from a rotation, but at most three
/// times the largest relative change of length of its edges, and the largest change itself. A
/// sliver (a tetrahedron nearly flat) turns its vertices' small differences across its height
/// into a stretch of hundreds that no point of the map undergoes: its transform alone gave
/// points of a centimetre map sigmas of kilometres. Its edges' lengths change as much as the
/// map's distances there do.
std::vector<TetStrain> tetStrains(const RubberSheet& sheet) {
  const auto& src = sheet.sources();
  const auto& dst = sheet.targets();
  std::vector<TetStrain> out;
  out.reserve(sheet.numTetrahedra() + 1);
  for (std::size_t t = 0; t < sheet.numTetrahedra(); ++t) {
    const auto& v = sheet.tetrahedra()[t];
    double change = 0.0, stretch = 0.0;
    for (int a = 0; a < 4; ++a) {
      for (int b = a + 1; b < 4; ++b) {
        const auto i = static_cast<std::size_t>(v[a]), k = static_cast<std::size_t>(v[b]);
        const double from = (src[i] - src[k]).norm();
        const double by = std::abs((dst[i] - dst[k]).norm() - from);
        change = std::max(change, by);
        if (from > 0.0) stretch = std::max(stretch, by / from);
      }
    }
    const double ratio =
        std::min(strainOf(sheet.affineAt({static_cast<int>(t), false})), kShear * stretch);
    out.push_back({static_cast<float>(ratio), static_cast<float>(change)});
  }
  return out;
}

}  // namespace

PointSigmaField::PointSigmaField(const Trajectory& result, const PoseSigmas& sigmas,
                                 const RubberSheet& sheet, const PointSigmaModel& model) {
  if (result.empty()) throw Error("point sigma: no pose");
  strain_ = tetStrains(sheet);
  strain_.push_back({static_cast<float>(strainOf(sheet.outsideTransform())),
                     std::numeric_limits<float>::infinity()});
  for (const auto& p : result) positions_.push_back(p.position);
  Eigen::Vector2d lo = positions_[0].head<2>(), hi = lo;
  for (const auto& p : positions_) {
    lo = lo.cwiseMin(p.head<2>());
    hi = hi.cwiseMax(p.head<2>());
  }
  origin_ << lo - Eigen::Vector2d::Constant(kPadding), positions_[0].z();
  const Eigen::Vector2d extent = hi - lo + Eigen::Vector2d::Constant(2 * kPadding);
  cell_ = std::max(kMinCell, extent.maxCoeff() / kMaxCells);
  inv_cell_ = static_cast<float>(1.0 / cell_);
  nx_ = std::max(1, static_cast<int>(std::ceil(extent.x() / cell_)));
  ny_ = std::max(1, static_cast<int>(std::ceil(extent.y() / cell_)));
  last_x_ = static_cast<float>(nx_ - 1);
  last_y_ = static_cast<float>(ny_ - 1);
  nearest_.assign(static_cast<std::size_t>(nx_) * ny_, -1);
  seed();
  sweep(true);
  sweep(false);
  const auto f = [](double v) { return static_cast<float>(v); };
  heading2_ = f(model.heading * model.heading);
  tilt2_ = f(model.tilt * model.tilt);
  reach2_ = f(model.strain_reach * model.strain_reach);
  const auto terms = [](const TetStrain& s) {
    return TetTerms{2.0F * s.ratio * s.ratio, s.change * s.change};
  };
  tet_terms_.push_back(terms(strain_.back()));
  for (std::size_t t = 0; t + 1 < strain_.size(); ++t) tet_terms_.push_back(terms(strain_[t]));
  // Without the poses' sigmas nothing is known: every point's sigma is infinite.
  const bool known = sigmas.h.size() == result.size() && sigmas.v.size() == result.size();
  const double inf = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < positions_.size(); ++i) {
    const Eigen::Vector3d q = positions_[i] - origin_;
    const double h = known ? sigmas.h[i] : inf, v = known ? sigmas.v[i] : inf;
    poses_.push_back({f(q.x()), f(q.y()), f(q.z()), f(h * h + model.scatter_h * model.scatter_h),
                      f(v * v + model.scatter_v * model.scatter_v)});
  }
  cells_.resize(nearest_.size());
  for (std::size_t c = 0; c < nearest_.size(); ++c) {
    cells_[c] = poses_[static_cast<std::size_t>(nearest_[c])];
  }
}

double PointSigmaField::planDistance2(std::size_t cell, std::int32_t pose) const {
  const double cx = origin_.x() + (static_cast<double>(cell % nx_) + 0.5) * cell_;
  const double cy = origin_.y() + (static_cast<double>(cell / nx_) + 0.5) * cell_;
  const Eigen::Vector3d& p = positions_[static_cast<std::size_t>(pose)];
  return (p.x() - cx) * (p.x() - cx) + (p.y() - cy) * (p.y() - cy);
}

void PointSigmaField::seed() {
  for (std::size_t i = 0; i < positions_.size(); ++i) {
    const auto cx = static_cast<int>((positions_[i].x() - origin_.x()) / cell_);
    const auto cy = static_cast<int>((positions_[i].y() - origin_.y()) / cell_);
    const std::size_t c = static_cast<std::size_t>(std::clamp(cy, 0, ny_ - 1)) * nx_ +
                          static_cast<std::size_t>(std::clamp(cx, 0, nx_ - 1));
    const auto pose = static_cast<std::int32_t>(i);
    if (nearest_[c] < 0 || planDistance2(c, pose) < planDistance2(c, nearest_[c])) {
      nearest_[c] = pose;
    }
  }
}

/// One pass of a nearest-seed propagation: each cell takes the nearer of its pose and those of
/// the neighbours already visited in this pass (row by row, then back along the row).
void PointSigmaField::sweep(bool forward) {
  const int dir = forward ? 1 : -1;
  auto take = [&](std::size_t c, int x, int y) {
    if (x < 0 || y < 0 || x >= nx_ || y >= ny_) return;
    const std::int32_t q = nearest_[static_cast<std::size_t>(y) * nx_ + x];
    if (q < 0) return;
    if (nearest_[c] < 0 || planDistance2(c, q) < planDistance2(c, nearest_[c])) nearest_[c] = q;
  };
  for (int k = 0; k < ny_; ++k) {
    const int y = forward ? k : ny_ - 1 - k;
    for (int j = 0; j < nx_; ++j) {
      const int x = forward ? j : nx_ - 1 - j;
      const std::size_t c = static_cast<std::size_t>(y) * nx_ + x;
      take(c, x - dir, y);
      take(c, x - 1, y - dir);
      take(c, x, y - dir);
      take(c, x + 1, y - dir);
    }
    for (int j = 0; j < nx_; ++j) {
      const int x = forward ? nx_ - 1 - j : j;
      take(static_cast<std::size_t>(y) * nx_ + x, x + dir, y);
    }
  }
}

std::size_t PointSigmaField::nearestPose(const Eigen::Vector3d& enu) const {
  return static_cast<std::size_t>(nearest_[cellOf(static_cast<float>(enu.x() - origin_.x()),
                                                  static_cast<float>(enu.y() - origin_.y()))]);
}

void PointSigmaField::sigmas(std::size_t n, const float* x, const float* y, const float* z,
                             const int* tet, float* __restrict h, float* __restrict v) const {
  // The cells and the tetrahedra's entries first, then the lookups with the arithmetic: each
  // loop in vector lanes, the lookups' loads lane by lane (this file is built without errno
  // and CGAL's rounding mode, either of which keeps the loops scalar). Split from the
  // arithmetic into arrays of their own, the lookups ran no faster.
  n = std::min(n, kBatch);
  std::int32_t cell[kBatch];
  for (std::size_t k = 0; k < n; ++k) {
    const float fx = within(x[k] * inv_cell_, last_x_), fy = within(y[k] * inv_cell_, last_y_);
    cell[k] = static_cast<std::int32_t>(fy) * nx_ + static_cast<std::int32_t>(fx);
  }
  std::uint32_t term[kBatch];
  for (std::size_t k = 0; k < n; ++k) term[k] = static_cast<std::uint32_t>(termsIndex(tet[k]));
  for (std::size_t k = 0; k < n; ++k) {
    const CellPose& c = cells_[static_cast<std::size_t>(cell[k])];
    const TetTerms& s = tet_terms_[term[k]];
    const float dx = x[k] - c.x, dy = y[k] - c.y, dz = z[k] - c.z;
    combine(c.var_h, c.var_v, bounded(dx * dx + dy * dy), bounded(dz * dz), s.bend2, s.cap2, h[k],
            v[k]);
  }
}

void PointSigmaField::sigmasOfPoses(std::size_t n, const float* x, const float* y, const float* z,
                                    const int* pose, float* __restrict h,
                                    float* __restrict v) const {
  // A point's own pose is near the poses of the points before it (a few hundred kB of poses
  // for a drive: in cache whatever the points' order); one that names no pose takes its cell's.
  n = std::min(n, kBatch);
  const auto poses = static_cast<std::uint32_t>(poses_.size());
  for (std::size_t k = 0; k < n; ++k) {
    const auto i = static_cast<std::uint32_t>(pose[k]);
    const CellPose& c = i < poses ? poses_[i] : cells_[cellOf(x[k], y[k])];
    const float dx = x[k] - c.x, dy = y[k] - c.y, dz = z[k] - c.z;
    combine(c.var_h, c.var_v, bounded(dx * dx + dy * dy), bounded(dz * dz), 0.0F, 0.0F, h[k], v[k]);
  }
}

void PointSigmaBatch::flush() {
  float h[kSize], v[kSize];
  const std::size_t n = n_;  // kept apart: the writes below could alias the member
  if (moved_ == Moved::kBySheet) {
    sink_.field->sigmas(n, x_, y_, z_, by_, h, v);
  } else {
    sink_.field->sigmasOfPoses(n, x_, y_, z_, by_, h, v);
  }
  for (std::size_t k = 0; k < n; ++k) {
    std::uint8_t* at = sink_.out + index_[k] * sink_.stride;
    std::memcpy(at, &h[k], sizeof(float));
    std::memcpy(at + sizeof(float), &v[k], sizeof(float));
  }
  n_ = 0;
}

void widenPoints(const std::uint8_t* data, std::size_t point_step, std::size_t n,
                 std::uint8_t* out) {
  const float none[2] = {std::numeric_limits<float>::quiet_NaN(),
                         std::numeric_limits<float>::quiet_NaN()};
  const std::size_t wide = point_step + kPointSigmaBytes;
  for (std::size_t i = 0; i < n; ++i) {
    std::memcpy(out + i * wide, data + i * point_step, point_step);
    std::memcpy(out + i * wide + point_step, none, kPointSigmaBytes);
  }
}

}  // namespace flexcloud
