#include "truth_maps.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <random>
#include <utility>

#include "flexcloud/input/trajectory.h"
#include "flexcloud/param_table.h"
#include "flexcloud/params.h"
#include "flexcloud/uncertainty/point_sigma.h"
#include "flexcloud/warp/pose_rebuild.h"

namespace flexcloud::study {
namespace {

constexpr double kRevisitRadius = 30.0;  // m
constexpr double kOtherPass = 60.0;      // s between two poses of different passes
constexpr double kSensorHeight = 1.7;    // m above the road
constexpr double kBandEdges[kBands + 1] = {0.0, 10.0, 30.0, 50.0};
// m: the cells within which scoreFloor() lets a warp be any affine map.
constexpr double kFloorCell = 5.0;

/// A body-frame offset a car's LiDAR sees: ground below (4 in 10), a wall beside (4 in 10), a
/// pole (2 in 10), 2-50 m out.
Eigen::Vector3d scanOffset(const BodyAxes& a, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double kind = u(rng), side = u(rng) < 0.5 ? -1.0 : 1.0;
  double along, across, height;
  if (kind < 0.4) {  // the road and the ground beside it
    const double r = 2.0 + 28.0 * u(rng) * u(rng), bearing = 2.0 * M_PI * u(rng);
    along = r * std::cos(bearing), across = r * std::sin(bearing);
    height = -kSensorHeight + 0.1 * (u(rng) - 0.5);
  } else if (kind < 0.8) {  // walls, facades, embankments
    along = -30.0 + 60.0 * u(rng);
    across = side * (4.0 + 46.0 * u(rng));
    height = -kSensorHeight + 6.0 * u(rng);
  } else {  // poles, trees, signs
    along = -20.0 + 40.0 * u(rng);
    across = side * (3.0 + 12.0 * u(rng));
    height = -kSensorHeight + 5.0 * u(rng);
  }
  const double r = std::hypot(along, across);
  if (r > 50.0) along *= 50.0 / r, across *= 50.0 / r;
  return along * a.ahead + across * a.left + height * a.up;
}

/// The cell of a grid in plan (cells of `size` m) that holds p.
using PlanCell = std::pair<long, long>;
PlanCell planCell(const Eigen::Vector3d& p, double size) {
  return {static_cast<long>(std::floor(p.x() / size)), static_cast<long>(std::floor(p.y() / size))};
}

/// Positions by cell, with the stamp of each: whether a position of another pass lies near.
class PassGrid {
 public:
  PassGrid(const std::vector<Eigen::Vector3d>& at, const std::vector<double>& stamp) {
    for (std::size_t i = 0; i < at.size(); ++i) {
      if (at[i].allFinite()) cells_[planCell(at[i], kRevisitRadius)].push_back({at[i], stamp[i]});
    }
  }
  bool otherPassNear(const Eigen::Vector3d& q, double stamp) const {
    const auto [cx, cy] = planCell(q, kRevisitRadius);
    for (long dx = -1; dx <= 1; ++dx) {
      for (long dy = -1; dy <= 1; ++dy) {
        const auto it = cells_.find({cx + dx, cy + dy});
        if (it == cells_.end()) continue;
        for (const auto& [p, t] : it->second) {
          if (std::abs(t - stamp) > kOtherPass && (p - q).head<2>().norm() < kRevisitRadius) {
            return true;
          }
        }
      }
    }
    return false;
  }

 private:
  std::map<PlanCell, std::vector<std::pair<Eigen::Vector3d, double>>> cells_;
};

Spread spreadOf(std::vector<double> e) {
  Spread s;
  s.points = e.size();
  if (e.empty()) return s;
  double sq = 0.0;
  for (double x : e) sq += x * x;
  s.rmse = std::sqrt(sq / static_cast<double>(e.size()));
  std::sort(e.begin(), e.end());
  s.p95 = e[static_cast<std::size_t>(0.95 * static_cast<double>(e.size() - 1))];
  s.max = e.back();
  return s;
}

void printSpread(const Spread& h, const Spread& v) {
  std::printf(" %.3f / %.3f / %.2f | %.3f / %.3f / %.2f |", h.rmse, h.p95, h.max, v.rmse, v.p95,
              v.max);
}

/// A row of printTruthMapRows() up to its sigma columns.
void printScoreRow(const std::string& drive, const char* what, const MapScore& s) {
  std::printf("| %s | %s |", drive.c_str(), what);
  printSpread(s.h, s.v);
  for (int b = 0; b < kBands; ++b) printSpread(s.band_h[b], s.band_v[b]);
  printSpread(s.away_h, s.away_v);
}

}  // namespace

DriveMap makeDriveMap(const TruthDrive& d, std::size_t every, std::size_t per_scan,
                      std::uint64_t seed) {
  DriveMap m;
  const Trajectory& poses = d.input.poses;
  const BodyAxes axes = bodyAxes(poses);
  std::mt19937_64 rng(seed);
  std::vector<Eigen::Vector3d> slam_at, truth_at;
  std::vector<double> stamps;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    slam_at.push_back(poses[i].position);
    truth_at.push_back(d.truth_at_pose[i].position);
    stamps.push_back(poses[i].stamp);
  }
  const PassGrid by_truth(truth_at, stamps), by_slam(slam_at, stamps);
  // A scan's true place: the truth's body turned by the sensor's mount on it.
  Eigen::Isometry3d mount = Eigen::Isometry3d::Identity();
  mount.linear() = mountRotation(d);
  for (std::size_t i = 0; i < poses.size(); i += std::max<std::size_t>(1, every)) {
    if (!d.truth_at_pose[i].position.allFinite()) continue;
    const Eigen::Isometry3d s = isometryOf(poses[i]), t = isometryOf(d.truth_at_pose[i]) * mount;
    for (std::size_t k = 0; k < per_scan; ++k) {
      const Eigen::Vector3d o = scanOffset(axes, rng);
      m.slam.push_back(s * o);
      m.truth.push_back(t * o);
      m.pose.push_back(i);
      m.range.push_back(static_cast<float>((o - o.dot(axes.up) * axes.up).norm()));
      m.revisit.push_back(by_truth.otherPassNear(m.truth.back(), poses[i].stamp) ||
                          by_slam.otherPassNear(m.slam.back(), poses[i].stamp));
    }
  }
  return m;
}

DriveMap makeDenseDriveMap(const TruthDrive& d) { return makeDriveMap(d, 1, 200, 2); }

MapScore scoreMap(
    const DriveMap& m,
    const std::function<Eigen::Vector3d(const Eigen::Vector3d&, std::size_t)>& place) {
  std::vector<double> h, v, bh[kBands], bv[kBands], ah, av;
  for (std::size_t k = 0; k < m.slam.size(); ++k) {
    // A SLAM writes its map in float32.
    const Eigen::Vector3d e = place(m.slam[k].cast<float>().cast<double>(), k) - m.truth[k];
    const double eh = e.head<2>().norm(), ev = std::abs(e.z());
    h.push_back(eh), v.push_back(ev);
    for (int b = 0; b < kBands; ++b) {
      if (m.range[k] >= kBandEdges[b] && m.range[k] < kBandEdges[b + 1]) {
        bh[b].push_back(eh), bv[b].push_back(ev);
      }
    }
    if (!m.revisit[k]) ah.push_back(eh), av.push_back(ev);
  }
  MapScore s;
  s.h = spreadOf(std::move(h)), s.v = spreadOf(std::move(v));
  for (int b = 0; b < kBands; ++b) {
    s.band_h[b] = spreadOf(std::move(bh[b])), s.band_v[b] = spreadOf(std::move(bv[b]));
  }
  s.away_h = spreadOf(std::move(ah)), s.away_v = spreadOf(std::move(av));
  return s;
}

MapScore scoreSheet(const DriveMap& m, const GeoreferenceResult& r) {
  return scoreMap(m, [&](const Eigen::Vector3d& p, std::size_t) { return r.sheet->transform(p); });
}

/// The share of the points within 2.45 sigma_h of their truth horizontally, by band, and within
/// 1.96 sigma_v vertically, each point's place and sigma given by `placed` (point index).
SigmaCover sigmaCover(
    const DriveMap& m,
    const std::function<std::pair<Eigen::Vector3d, PointSigma>(std::size_t)>& placed) {
  std::size_t in_h[kBands] = {0, 0, 0}, of[kBands] = {0, 0, 0}, in_v = 0;
  for (std::size_t k = 0; k < m.slam.size(); ++k) {
    const auto [enu, s] = placed(k);
    const Eigen::Vector3d e = enu - m.truth[k];
    in_v += std::abs(e.z()) <= 1.96 * s.v;
    for (int b = 0; b < kBands; ++b) {
      if (m.range[k] < kBandEdges[b] || m.range[k] >= kBandEdges[b + 1]) continue;
      ++of[b];
      in_h[b] += e.head<2>().norm() <= 2.45 * s.h;
    }
  }
  SigmaCover c;
  for (int b = 0; b < kBands; ++b) {
    c.band_h[b] =
        of[b] == 0 ? 0.0 : 100.0 * static_cast<double>(in_h[b]) / static_cast<double>(of[b]);
  }
  c.v =
      m.slam.empty() ? 0.0 : 100.0 * static_cast<double>(in_v) / static_cast<double>(m.slam.size());
  return c;
}

SigmaCover sheetSigmaCover(const DriveMap& m, const GeoreferenceResult& r, const Params& p) {
  const PointSigmaField field(r.rubbersheet, r.sigma, *r.sheet, pointSigmaModel(p));
  return sigmaCover(m, [&](std::size_t k) {
    const Eigen::Vector3d q = m.slam[k].cast<float>().cast<double>();
    const RubberSheet::Location loc = r.sheet->locate(q);
    const Eigen::Vector3d enu = RubberSheet::apply(r.sheet->affineAt(loc), q);
    return std::make_pair(enu, field.at(enu, loc.outside ? -1 : loc.tet));
  });
}

MapScore scoreOwnPose(const DriveMap& m, const TruthDrive& d, const GeoreferenceResult& r) {
  const Trajectory& fused = r.fusion ? r.fusion->poses : r.rubbersheet;
  return scoreMap(m, [&](const Eigen::Vector3d& p, std::size_t k) {
    const std::size_t i = m.pose[k];
    return Eigen::Vector3d(isometryOf(fused[i]) * (isometryOf(d.input.poses[i]).inverse() * p));
  });
}

namespace {

/// The SLAM's poses by horizontal cell of kNearestCell: the pose nearest to a point.
class NearestPose {
 public:
  explicit NearestPose(const Trajectory& poses) : poses_(poses) {
    for (std::size_t i = 0; i < poses.size(); ++i) {
      cells_[planCell(poses[i].position, kNearestCell)].push_back(i);
    }
  }
  std::size_t of(const Eigen::Vector3d& q) const {
    const auto [cx, cy] = planCell(q, kNearestCell);
    std::size_t best = 0;
    double best_d = std::numeric_limits<double>::infinity();
    // Rings of cells outward, until the ring lies beyond the nearest pose found.
    for (long ring = 0; ring <= kMaxRings && !(best_d < (ring - 1) * kNearestCell); ++ring) {
      for (long dx = -ring; dx <= ring; ++dx) {
        for (long dy = -ring; dy <= ring; ++dy) {
          if (std::max(std::abs(dx), std::abs(dy)) != ring) continue;
          const auto it = cells_.find({cx + dx, cy + dy});
          if (it == cells_.end()) continue;
          for (std::size_t i : it->second) {
            const double d = (poses_[i].position - q).norm();
            if (d < best_d) best_d = d, best = i;
          }
        }
      }
    }
    return best;
  }

 private:
  static constexpr double kNearestCell = 10.0;  // m
  static constexpr long kMaxRings = 100;
  const Trajectory& poses_;
  std::map<PlanCell, std::vector<std::size_t>> cells_;
};

}  // namespace

MapScore scoreNearestPose(const DriveMap& m, const TruthDrive& d, const GeoreferenceResult& r) {
  const Trajectory& fused = r.fusion ? r.fusion->poses : r.rubbersheet;
  const NearestPose nearest(d.input.poses);
  return scoreMap(m, [&](const Eigen::Vector3d& p, std::size_t) {
    const std::size_t i = nearest.of(p);
    return Eigen::Vector3d(isometryOf(fused[i]) * (isometryOf(d.input.poses[i]).inverse() * p));
  });
}

namespace {

/// The cell of a 3D grid (cells of `size` m) that holds p.
using SpaceCell = std::array<long, 3>;
SpaceCell spaceCell(const Eigen::Vector3d& p, double size) {
  return {static_cast<long>(std::floor(p.x() / size)), static_cast<long>(std::floor(p.y() / size)),
          static_cast<long>(std::floor(p.z() / size))};
}

/// Each of `which` points placed by the affine map, fitted by least squares per cell, that
/// takes the cell's points of `which` from the SLAM's map to their truth: no warp affine within
/// each cell places them better.
std::vector<Eigen::Vector3d> cellAffinePlaces(const DriveMap& m, const std::vector<bool>& which) {
  std::map<SpaceCell, std::vector<std::size_t>> cells;
  for (std::size_t k = 0; k < m.slam.size(); ++k) {
    if (which[k]) cells[spaceCell(m.slam[k], kFloorCell)].push_back(k);
  }
  std::vector<Eigen::Vector3d> out(m.slam.size(), Eigen::Vector3d::Zero());
  for (const auto& [cell, ks] : cells) {
    const Eigen::Vector3d centre = m.slam[ks.front()];
    Eigen::MatrixXd a(ks.size(), 4), b(ks.size(), 3);
    for (std::size_t j = 0; j < ks.size(); ++j) {
      a.row(static_cast<Eigen::Index>(j)) << (m.slam[ks[j]] - centre).transpose(), 1.0;
      b.row(static_cast<Eigen::Index>(j)) = (m.truth[ks[j]] - centre).transpose();
    }
    const Eigen::MatrixXd x = a.colPivHouseholderQr().solve(b);
    for (std::size_t j = 0; j < ks.size(); ++j) {
      out[ks[j]] = centre + (a.row(static_cast<Eigen::Index>(j)) * x).transpose();
    }
  }
  return out;
}

}  // namespace

MapScore scoreFloor(const DriveMap& m) {
  const std::vector<Eigen::Vector3d> all =
      cellAffinePlaces(m, std::vector<bool>(m.slam.size(), true));
  std::vector<bool> away(m.slam.size());
  for (std::size_t k = 0; k < away.size(); ++k) away[k] = !m.revisit[k];
  const std::vector<Eigen::Vector3d> apart = cellAffinePlaces(m, away);
  MapScore s = scoreMap(m, [&](const Eigen::Vector3d&, std::size_t k) { return all[k]; });
  const MapScore a = scoreMap(m, [&](const Eigen::Vector3d&, std::size_t k) { return apart[k]; });
  s.away_h = a.away_h, s.away_v = a.away_v;
  return s;
}

namespace {

/// The map saved with per-point time and rebuilt as the tool does it, with its point sigmas
/// where `field` is given.
struct RebuiltMap {
  struct Row {
    float x, y, z, pad;
    double time;
    float sigma_h, sigma_v;
  };
  std::vector<Row> rows;
  XyzLayout layout;

  Eigen::Vector3d at(std::size_t k) const {
    return layout.get(reinterpret_cast<const std::uint8_t*>(rows.data()) + k * sizeof(Row));
  }
};

RebuiltMap rebuildMap(const DriveMap& m, const TruthDrive& d, const GeoreferenceResult& r,
                      const PointSigmaField* field) {
  using Row = RebuiltMap::Row;
  RebuiltMap out;
  out.rows.resize(m.slam.size());
  for (std::size_t k = 0; k < out.rows.size(); ++k) {
    const Eigen::Vector3f p = m.slam[k].cast<float>();
    out.rows[k] = {p.x(), p.y(), p.z(), 0.0F, d.input.poses[m.pose[k]].stamp, 0.0F, 0.0F};
  }
  XyzLayout& layout = out.layout;
  layout.offset[0] = offsetof(Row, x), layout.offset[1] = offsetof(Row, y);
  layout.offset[2] = offsetof(Row, z);
  layout.point_step = sizeof(Row);
  layout.points = out.rows.size();
  PoseRebuild rebuild;
  rebuild.field.name = "time";
  rebuild.field.offset = offsetof(Row, time);
  const PoseCorrections corrections(r.poses, resultPoses(r), r.T_enu_map);
  rebuild.corrections = &corrections;
  auto* data = reinterpret_cast<std::uint8_t*>(out.rows.data());
  SigmaSink sink;
  if (field != nullptr) sink = {field, data + offsetof(Row, sigma_h), sizeof(Row)};
  rebuildPoints(data, layout, rebuild, 0, "map", neverCancelled(), sink);
  return out;
}

}  // namespace

MapScore scoreRebuilt(const DriveMap& m, const TruthDrive& d, const GeoreferenceResult& r) {
  const RebuiltMap map = rebuildMap(m, d, r, nullptr);
  return scoreMap(m, [&](const Eigen::Vector3d&, std::size_t k) { return map.at(k); });
}

SigmaCover rebuiltSigmaCover(const DriveMap& m, const TruthDrive& d, const GeoreferenceResult& r,
                             const Params& p) {
  const PointSigmaField field(r.rubbersheet, r.sigma, *r.sheet, pointSigmaModel(p));
  const RebuiltMap map = rebuildMap(m, d, r, &field);
  return sigmaCover(m, [&](std::size_t k) {
    return std::make_pair(map.at(k), PointSigma{map.rows[k].sigma_h, map.rows[k].sigma_v});
  });
}

void printTruthMapRows(const std::vector<std::string>& dirs, int control_points,
                       const std::vector<std::pair<std::string, std::string>>& sets) {
  std::printf(
      "| drive | map moved by | horizontal RMSE / p95 / MAX | vertical | 0-10 m, h | v | 10-30 m, "
      "h | v | 30-50 m, h | v | away from revisits, h | v | within 2.45 sigma_h, %% by band | "
      "within 1.96 sigma_v, %% |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const auto& dir : dirs) {
    for (const char* kind : {"rtk", "urban"}) {
      if (!std::filesystem::exists(dir + "/gnss_" + kind + ".txt")) continue;
      const TruthDrive d = loadTruthDrive(dir, kind);
      Params p;
      p.control_points = control_points;
      for (const auto& [k, v] : sets) paramTable().setText(p, k, v);
      const GeoreferenceResult r = georeference(d.input, p);
      const DriveMap m = makeDriveMap(d);
      printScoreRow(d.name, "the sheet", scoreSheet(m, r));
      const SigmaCover c = sheetSigmaCover(m, r, p);
      std::printf(" %.1f / %.1f / %.1f | %.1f |\n", c.band_h[0], c.band_h[1], c.band_h[2], c.v);
      printScoreRow(d.name, "its nearest pose", scoreNearestPose(m, d, r));
      std::printf(" - | - |\n");
      printScoreRow(d.name, "the best warp affine in 5 m cells", scoreFloor(makeDenseDriveMap(d)));
      std::printf(" - | - |\n");
      printScoreRow(d.name, "its points' time (rebuilt)", scoreRebuilt(m, d, r));
      const SigmaCover own = rebuiltSigmaCover(m, d, r, p);
      std::printf(" %.1f / %.1f / %.1f | %.1f |\n", own.band_h[0], own.band_h[1], own.band_h[2],
                  own.v);
      std::fflush(stdout);
    }
  }
}

}  // namespace flexcloud::study
