// A map whose points know their pose, rebuilt: each point moved with its own pose's correction
// (result pose times the SLAM pose inverted), at its time or scan index, on a drive whose every
// pose has a correction of its own; the fields that name poses, and the streamed file.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>

#include "flexcloud/io/atomic_file.h"
#include "flexcloud/io/cloud_layout.h"
#include "flexcloud/io/keyframes.h"
#include "flexcloud/io/map_stream.h"
#include "flexcloud/io/pcd_io.h"
#include "flexcloud/io/scan_map.h"
#include "flexcloud/uncertainty/point_sigma.h"
#include "flexcloud/warp/pose_rebuild.h"
#include "test_util.h"

namespace flexcloud {
namespace {

using F = pcl::PCLPointField;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

Eigen::Isometry3d isometry(const Pose& p) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = p.orientation.toRotationMatrix();
  t.translation() = p.position;
  return t;
}

Pose poseOf(double stamp, const Eigen::Isometry3d& t) {
  return {stamp, t.translation(), Eigen::Quaterniond(t.linear())};
}

/// The correction of pose i: a turn of 0.5 degrees per pose about the vertical and a shift.
Eigen::Isometry3d correctionOf(int i) {
  Eigen::Isometry3d d = Eigen::Isometry3d::Identity();
  d.linear() = Eigen::AngleAxisd(0.5 * i * M_PI / 180.0, Eigen::Vector3d::UnitZ()).matrix();
  d.translation() = Eigen::Vector3d(0.1 * i, 2.0, 0.3 - 0.05 * i);
  return d;
}

/// Eleven SLAM poses 0.1 s apart, driving 1 m a pose and turning 1 degree a pose; each result
/// pose is its own correction times it.
struct Drive {
  Trajectory slam, result;
  Drive() {
    for (int i = 0; i <= 10; ++i) {
      Eigen::Isometry3d s = Eigen::Isometry3d::Identity();
      s.linear() = Eigen::AngleAxisd(i * M_PI / 180.0, Eigen::Vector3d::UnitZ()).matrix();
      s.translation() = Eigen::Vector3d(1000.0 + i, 2000.0, 30.0);
      slam.push_back(poseOf(100.0 + 0.1 * i, s));
      result.push_back(poseOf(100.0 + 0.1 * i, correctionOf(i) * s));
    }
  }
};

const Eigen::Vector3d kBody(3.0, 25.0, -1.7);  // a point 25 m beside the car, on the ground

/// A cloud of x, y, z (float64) and the pose field `type`, one point per entry.
pcl::PCLPointCloud2 cloudOf(const std::vector<Eigen::Vector3d>& pts,
                            const std::vector<double>& field, std::uint8_t type) {
  pcl::PCLPointCloud2 c =
      test::packedCloud({{"x", F::FLOAT64}, {"y", F::FLOAT64}, {"z", F::FLOAT64}, {"time", type}},
                        static_cast<std::uint32_t>(pts.size()));
  for (std::size_t i = 0; i < pts.size(); ++i) {
    std::uint8_t* p = c.data.data() + i * c.point_step;
    std::memcpy(p, pts[i].data(), 24);
    if (type == F::FLOAT64) {
      std::memcpy(p + 24, &field[i], 8);
    } else {
      const auto v = static_cast<std::uint32_t>(field[i]);
      std::memcpy(p + 24, &v, 4);
    }
  }
  return c;
}

Eigen::Vector3d pointOf(const pcl::PCLPointCloud2& c, std::size_t i) {
  Eigen::Vector3d p;
  std::memcpy(p.data(), c.data.data() + i * c.point_step, 24);
  return p;
}

WarpStats rebuild(pcl::PCLPointCloud2& c, const PoseCorrections& corrections) {
  const std::optional<PointPoseField> f = pointPoseField(c.fields, "time", "map");
  return rebuildPoints(c.data.data(), xyzLayout(c, "map"), PoseRebuild{*f, &corrections}, 2);
}

TEST(PoseRebuild, EachPointMovesWithItsOwnPosesCorrection) {
  const Drive d;
  const PoseCorrections corrections(d.slam, d.result, Eigen::Isometry3d::Identity());
  std::vector<Eigen::Vector3d> pts, expected;
  std::vector<double> times, indices;
  for (int i = 0; i <= 10; ++i) {
    pts.push_back(isometry(d.slam[i]) * kBody);
    expected.push_back(isometry(d.result[i]) * kBody);
    times.push_back(d.slam[i].stamp);
    indices.push_back(i);
  }
  for (const auto& [values, type] :
       {std::make_pair(times, F::FLOAT64), std::make_pair(indices, F::UINT32)}) {
    pcl::PCLPointCloud2 c = cloudOf(pts, values, type);
    const WarpStats s = rebuild(c, corrections);
    EXPECT_EQ(s.points, 11u);
    EXPECT_EQ(s.outside, 0u);
    for (std::size_t i = 0; i < pts.size(); ++i) {
      // The sheet would move each point by a blend of its neighbours' corrections; here the
      // point 25 m out moves by its own pose's, turned 0.5 degree a pose.
      EXPECT_LT((pointOf(c, i) - expected[i]).norm(), 1e-6) << "point " << i << " type " << type;
    }
  }
}

TEST(PoseRebuild, BetweenPosesTheCorrectionOfTheInstant) {
  // One correction for the whole drive: a point at any instant between two poses moves by it.
  Drive d;
  const Eigen::Isometry3d one = correctionOf(7);
  for (std::size_t i = 0; i < d.slam.size(); ++i) {
    d.result[i] = poseOf(d.slam[i].stamp, one * isometry(d.slam[i]));
  }
  const PoseCorrections corrections(d.slam, d.result, Eigen::Isometry3d::Identity());
  const std::vector<Eigen::Vector3d> pts = {{1003.4, 2010.0, 28.0}, {900.0, 2500.0, 10.0}};
  pcl::PCLPointCloud2 c = cloudOf(pts, {100.337, 100.951}, F::FLOAT64);
  rebuild(c, corrections);
  for (std::size_t i = 0; i < pts.size(); ++i) {
    EXPECT_LT((pointOf(c, i) - one * pts[i]).norm(), 1e-6) << i;
  }
}

TEST(PoseRebuild, BetweenPosesThePosesOfTheInstant) {
  // The correction turns 0.5 degrees from pose to pose: a point 50 m out, seen between two
  // poses, lands where the SLAM's and the result's poses interpolated at its instant put it.
  const Drive d;
  const PoseCorrections corrections(d.slam, d.result, Eigen::Isometry3d::Identity());
  const auto at = [](const Pose& a, const Pose& b, double w) {
    Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
    t.linear() = a.orientation.slerp(w, b.orientation).toRotationMatrix();
    t.translation() = a.position + w * (b.position - a.position);
    return t;
  };
  std::vector<Eigen::Vector3d> pts, expected;
  std::vector<double> times;
  for (const double w : {0.1, 0.3, 0.5, 0.77, 0.95}) {
    for (std::size_t i : {0, 4, 9}) {
      const Eigen::Vector3d body(10.0, 48.0, 5.0);
      pts.push_back(at(d.slam[i], d.slam[i + 1], w) * body);
      expected.push_back(at(d.result[i], d.result[i + 1], w) * body);
      times.push_back(d.slam[i].stamp + w * 0.1);
    }
  }
  pcl::PCLPointCloud2 c = cloudOf(pts, times, F::FLOAT64);
  rebuild(c, corrections);
  double worst = 0.0;
  for (std::size_t i = 0; i < pts.size(); ++i)
    worst = std::max(worst, (pointOf(c, i) - expected[i]).norm());
  std::printf("worst %.3g m\n", worst);
  EXPECT_LT(worst, 1e-4);
}

TEST(PoseRebuild, PointsThatNameNoPoseAreMovedRigidlyAndCounted) {
  const Drive d;
  Eigen::Isometry3d rigid = Eigen::Isometry3d::Identity();
  rigid.translation() = Eigen::Vector3d(-5.0, 7.0, 1.0);
  const PoseCorrections corrections(d.slam, d.result, rigid);
  const Eigen::Vector3d p(1001.0, 2003.0, 29.0);
  const std::vector<Eigen::Vector3d> pts = {p, p, p, p, {kNaN, kNaN, kNaN}};
  // NaN time; half a second after the last pose (a scan's sweep: held at the last pose);
  // five seconds after it; before the first by 2 s; a NaN point.
  pcl::PCLPointCloud2 c = cloudOf(pts, {kNaN, 101.5, 106.0, 98.0, 100.0}, F::FLOAT64);
  const WarpStats s = rebuild(c, corrections);
  EXPECT_EQ(s.points, 5u);
  EXPECT_EQ(s.outside, 3u);
  EXPECT_EQ(s.non_finite, 1u);
  EXPECT_LT((pointOf(c, 0) - rigid * p).norm(), 1e-9);
  const Eigen::Isometry3d last = isometry(d.result[10]) * isometry(d.slam[10]).inverse();
  EXPECT_LT((pointOf(c, 1) - last * p).norm(), 1e-6);
  EXPECT_LT((pointOf(c, 2) - rigid * p).norm(), 1e-9);
  EXPECT_LT((pointOf(c, 3) - rigid * p).norm(), 1e-9);
  EXPECT_TRUE(std::isnan(pointOf(c, 4).x()));
}

// With sigmas asked for, each rebuilt point takes the sigma of its own pose, the one nearest
// its time (PointSigmaField::ofPose()); a point that names no pose, its cell's; a NaN point,
// NaN. The poses' sigmas grow by 1 cm a pose: the pose before a point's own gives it at least
// 4 mm less.
TEST(PoseRebuild, EachPointTakesTheSigmaOfItsOwnPose) {
  const Drive d;
  const PoseCorrections corrections(d.slam, d.result, Eigen::Isometry3d::Identity());
  PoseSigmas pose_sigmas;
  for (int i = 0; i <= 10; ++i) {
    pose_sigmas.h.push_back(0.05 + 0.01 * i);
    pose_sigmas.v.push_back(0.1 + 0.02 * i);
  }
  std::vector<Eigen::Vector3d> src, dst;
  for (double x : {0.0, 3000.0})
    for (double y : {1000.0, 3000.0})
      for (double z : {-100.0, 100.0}) src.emplace_back(x, y, z);
  Affine34 identity = Affine34::Zero();
  identity.leftCols<3>().setIdentity();
  const RubberSheet sheet(src, src, identity);
  // A small heading term (0.5 mrad), so that the poses' own sigmas, 1 cm apart, tell them apart
  // beyond the distance term.
  PointSigmaModel model;
  model.heading = 0.0005;
  const PointSigmaField field(d.result, pose_sigmas, sheet, model);
  std::vector<Eigen::Vector3d> pts;
  std::vector<double> times;
  std::vector<int> own;
  for (int i = 0; i < 10; ++i) {
    for (const double after : {0.03, 0.07}) {  // nearer pose i, then pose i + 1
      pts.push_back(isometry(d.slam[i]) * kBody);
      times.push_back(d.slam[i].stamp + after);
      own.push_back(after < 0.05 ? i : i + 1);
    }
  }
  pts.push_back(pts[0]);
  times.push_back(kNaN);
  own.push_back(PointSigmaField::kNoPose);
  pts.emplace_back(kNaN, kNaN, kNaN);
  times.push_back(100.0);
  pcl::PCLPointCloud2 c = cloudOf(pts, times, F::FLOAT64);
  std::vector<float> out(2 * pts.size(), 0.0F);
  const SigmaSink sink{&field, reinterpret_cast<std::uint8_t*>(out.data()), 2 * sizeof(float)};
  const std::optional<PointPoseField> f = pointPoseField(c.fields, "time", "map");
  rebuildPoints(c.data.data(), xyzLayout(c, "map"), PoseRebuild{*f, &corrections}, 2, "map",
                neverCancelled(), sink);
  for (std::size_t k = 0; k < own.size(); ++k) {
    const PointSigma expected = field.ofPose(pointOf(c, k), own[k]);
    EXPECT_NEAR(out[2 * k], expected.h, 1e-6) << "point " << k;
    EXPECT_NEAR(out[2 * k + 1], expected.v, 1e-6) << "point " << k;
    if (own[k] > 0) {
      EXPECT_GT(out[2 * k], field.ofPose(pointOf(c, k), own[k] - 1).h + 0.004F) << "point " << k;
    }
  }
  EXPECT_TRUE(std::isnan(out[2 * own.size()]));
}

TEST(PoseRebuild, TheFieldsThatNamePoses) {
  const auto fields = [](std::vector<std::pair<std::string, std::uint8_t>> f) {
    return test::packedCloud(f, 1).fields;
  };
  // A Velodyne's float32 time is the offset within its sweep: not taken by auto.
  EXPECT_FALSE(pointPoseField(fields({{"x", F::FLOAT32}, {"time", F::FLOAT32}}), "auto", "m"));
  const auto t = pointPoseField(
      fields({{"x", F::FLOAT32}, {"scan_id", F::UINT16}, {"timestamp", F::FLOAT64}}), "auto", "m");
  ASSERT_TRUE(t);
  EXPECT_EQ(t->name, "timestamp");
  EXPECT_EQ(t->kind, PointPoseField::Kind::kTime);
  const auto i = pointPoseField(fields({{"x", F::FLOAT32}, {"scan_id", F::UINT16}}), "auto", "m");
  ASSERT_TRUE(i);
  EXPECT_EQ(i->kind, PointPoseField::Kind::kIndex);
  EXPECT_EQ(i->offset, 4u);
  EXPECT_FALSE(pointPoseField(fields({{"timestamp", F::FLOAT64}}), "none", "m"));
  EXPECT_EQ(test::errorOf([&] {
              pointPoseField(fields({{"time", F::FLOAT32}}), "time", "m");
            }),
            "m: map_pose_field 'time' is neither float64 (a time) nor an integer (a pose's "
            "index): type 7, count 1");
  EXPECT_EQ(test::errorOf([&] {
              pointPoseField(fields({{"x", F::FLOAT32}}), "stamp", "m");
            }),
            "m: map_pose_field 'stamp': no such field (auto: find one; none: move the map by the "
            "rubber sheet)");
}

TEST(PoseRebuild, TimesOnAnotherClockAreRefusedOrLeftToTheSheet) {
  const Drive d;
  const PoseCorrections corrections(d.slam, d.result, Eigen::Isometry3d::Identity());
  const auto sweep = [](const PointPoseField&) { return std::vector<double>{0.0, 0.05, 0.1}; };
  const auto fields = test::packedCloud({{"x", F::FLOAT32}, {"time", F::FLOAT64}}, 1).fields;
  const MapMotion m = mapMotion(fields, "auto", corrections, sweep, "map.pcd");
  EXPECT_FALSE(m.rebuild);
  EXPECT_EQ(m.note,
            "map.pcd: field 'time' holds 0.000 to 0.100; the trajectory's stamps run from "
            "100.000 to 101.000 s: not the SLAM's clock; the map is moved by the rubber sheet");
  EXPECT_EQ(test::errorOf([&] { mapMotion(fields, "time", corrections, sweep, "map.pcd"); }),
            "map.pcd: map_pose_field: field 'time' holds 0.000 to 0.100; the trajectory's stamps "
            "run from 100.000 to 101.000 s: not the SLAM's clock");
  const auto on_clock = [](const PointPoseField&) { return std::vector<double>{100.2, 100.9}; };
  EXPECT_TRUE(mapMotion(fields, "auto", corrections, on_clock, "map.pcd").rebuild);
}

TEST(PoseRebuild, TheStreamedFileIsRebuiltAndKeepsEveryOtherField) {
  const Drive d;
  const PoseCorrections corrections(d.slam, d.result, Eigen::Isometry3d::Identity());
  const std::string dir = ::testing::TempDir() + "rebuild_" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  // float32 x, y, z, an intensity and the time, as a LiDAR SLAM saves a map: 3000 points.
  const std::size_t n = 3000;
  pcl::PCLPointCloud2 c = test::packedCloud({{"x", F::FLOAT32},
                                             {"y", F::FLOAT32},
                                             {"z", F::FLOAT32},
                                             {"intensity", F::FLOAT32},
                                             {"time", F::FLOAT64}},
                                            static_cast<std::uint32_t>(n));
  std::vector<Eigen::Vector3d> expected;
  for (std::size_t k = 0; k < n; ++k) {
    const int i = static_cast<int>(k % 11);
    const Eigen::Vector3d body(0.01 * static_cast<double>(k), 20.0, -1.7);
    const Eigen::Vector3f p = (isometry(d.slam[i]) * body).cast<float>();
    expected.push_back(isometry(d.result[i]) * isometry(d.slam[i]).inverse() * p.cast<double>());
    std::uint8_t* row = c.data.data() + k * c.point_step;
    const float intensity = static_cast<float>(k);
    std::memcpy(row, p.data(), 12);
    std::memcpy(row + 12, &intensity, 4);
    std::memcpy(row + 16, &d.slam[i].stamp, 8);
  }
  writePcdBinary(dir + "/map.pcd", c);
  std::vector<Eigen::Vector3d> cube;  // a sheet that would leave every point where it is
  for (int k = 0; k < 8; ++k)
    cube.emplace_back(k & 1 ? 1e4 : -1e4, k & 2 ? 1e4 : -1e4, k & 4 ? 1e4 : -1e4);
  const RubberSheet unused(cube, cube, Affine34::Identity());
  for (bool in_place : {true, false}) {
    MapStreamOptions o;
    o.chunk_points = 700;
    o.in_place = in_place;
    o.corrections = &corrections;
    MapInfo info;
    warpPcdFile(dir + "/map.pcd", dir + "/out.pcd", unused, o, info);
    EXPECT_EQ(info.pose_field, "time");
    EXPECT_EQ(info.warp.points, n);
    EXPECT_EQ(info.warp.outside, 0u);
    const pcl::PCLPointCloud2 out = readPcd(dir + "/out.pcd");
    ASSERT_EQ(out.data.size(), c.data.size());
    const XyzLayout l = xyzLayout(out, "out");
    double worst = 0.0;
    for (std::size_t k = 0; k < n; ++k) {
      worst = std::max(worst, (l.get(out.data.data() + k * l.point_step) - expected[k]).norm());
      EXPECT_EQ(std::memcmp(out.data.data() + k * l.point_step + 12,
                            c.data.data() + k * c.point_step + 12, 12),
                0);
    }
    EXPECT_LT(worst, 3e-4) << (in_place ? "in place" : "pipeline");  // float32 at 2 km
  }
  std::filesystem::remove_all(dir);
}

TEST(Keyframes, TheDataTextRoundTripsAndBadOnesAreNamed) {
  const Drive d;
  const Pose p = d.result[7];
  const Pose back = parseKeyframeData(keyframeDataText(p), "k/data");
  EXPECT_NEAR(back.stamp, p.stamp, 1e-9);
  EXPECT_LT((back.position - p.position).norm(), 1e-9);
  EXPECT_LT(back.orientation.angularDistance(p.orientation), 1e-9);
  // As hdl_graph_slam writes it: six digits, odom and accum_distance after the estimate.
  const Pose h = parseKeyframeData(
      "stamp 1317 500000000\nestimate\n0 -1 0 12.5\n1 0 0 -3\n0 0 1 0.25\n0 0 0 1\nodom\n"
      "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\naccum_distance 12.7\n",
      "h/data");
  EXPECT_DOUBLE_EQ(h.stamp, 1317.5);
  EXPECT_LT((h.position - Eigen::Vector3d(12.5, -3.0, 0.25)).norm(), 1e-12);
  EXPECT_NEAR(h.orientation.angularDistance(
                  Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()))),
              0.0, 1e-9);
  EXPECT_EQ(test::errorOf([] { parseKeyframeData("estimate\n1 0 0 0\n", "a/data"); }),
            "a/data: estimate: row 2 missing");
  EXPECT_EQ(test::errorOf([] {
              parseKeyframeData("stamp 1 0\nestimate\n2 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n",
                                "b/data");
            }),
            "b/data: estimate is not a rigid transform (rotation off by 3.000000)");
  EXPECT_EQ(test::errorOf([] { parseKeyframeData("odom\n", "c/data"); }),
            "c/data: no 'stamp SEC NSEC' line");
  EXPECT_EQ(test::errorOf([] { parseKeyframeData("stamp 1 x\n", "d/data"); }),
            "d/data: stamp is not SEC NSEC: 'stamp 1 x'");
}

TEST(Keyframes, AFolderWithoutKeyframesOrWithTwoOfOneStampIsNamed) {
  const std::filesystem::path dir = test::tempFolder("keyframes");
  EXPECT_EQ(
      test::errorOf([&] { readKeyframes(dir.string()); }),
      dir.string() +
          ": no keyframe (a subfolder with data and cloud.pcd, as hdl_graph_slam saves them)");
  const Drive d;
  for (const char* name : {"000000", "000001"}) {
    std::filesystem::create_directories(dir / name);
    writeTextFile((dir / name / "data").string(), keyframeDataText(d.slam[3]));
    writePcdBinary((dir / name / "cloud.pcd").string(),
                   cloudOf({{1.0, 2.0, 3.0}}, {0.0}, F::FLOAT64));
  }
  EXPECT_NE(test::errorOf([&] { readKeyframes(dir.string()); }).find("have the same stamp"),
            std::string::npos);
  writeTextFile((dir / "000001" / "data").string(), keyframeDataText(d.slam[4]));
  const std::vector<Keyframe> k = readKeyframes(dir.string());
  ASSERT_EQ(k.size(), 2u);
  EXPECT_NEAR(k[1].pose.stamp, d.slam[4].stamp, 1e-9);
  std::filesystem::remove_all(dir);
}

TEST(ScanMap, RegisteredScansBecomeOneMapWithTheirStamps) {
  ScanMap m;
  const pcl::PCLPointCloud2 a = cloudOf({{1.0, 2.0, 3.0}, {4.0, 5.0, 6.0}}, {0.5, 0.5}, F::FLOAT64);
  const pcl::PCLPointCloud2 b = cloudOf({{7.0, 8.0, 9.0}}, {0.7}, F::FLOAT64);
  m.add(a, 100.0, "/scans");
  m.add(b, 100.1, "/scans");
  EXPECT_EQ(m.scans(), 2u);
  const pcl::PCLPointCloud2 c = m.cloud();
  ASSERT_EQ(c.width * c.height, 3u);
  EXPECT_EQ(c.fields.back().name, kScanTimeField);
  EXPECT_EQ(c.point_step, a.point_step + 8);
  const auto pose = pointPoseField(c.fields, kScanTimeField, "scans");
  ASSERT_TRUE(pose);
  EXPECT_DOUBLE_EQ(pose->read(c.data.data()), 100.0);
  EXPECT_DOUBLE_EQ(pose->read(c.data.data() + 2 * c.point_step), 100.1);
  EXPECT_LT(
      (xyzLayout(c, "scans").get(c.data.data() + 2 * c.point_step) - Eigen::Vector3d(7.0, 8.0, 9.0))
          .norm(),
      1e-12);
  // Every other field travels with its point (the scan's own time here).
  double own = 0.0;
  std::memcpy(&own, c.data.data() + c.point_step + 24, 8);
  EXPECT_DOUBLE_EQ(own, 0.5);
  const pcl::PCLPointCloud2 other =
      test::packedCloud({{"x", F::FLOAT32}, {"y", F::FLOAT32}, {"z", F::FLOAT32}}, 1);
  EXPECT_EQ(test::errorOf([&] { m.add(other, 100.2, "/scans"); }),
            "/scans: a scan's fields differ from those of the first scan");
  m.clear();
  EXPECT_EQ(m.scans(), 0u);
  m.add(other, 100.2, "/scans");  // a new first scan after clear()
  EXPECT_EQ(m.cloud().width, 1u);
}

TEST(ScanMap, ScansInTheBodysFrameArePlacedByTheirPoses) {
  const Drive d;
  ScanMap m;
  for (std::size_t i : {2, 6}) {
    m.add(cloudOf({kBody, {kNaN, kNaN, kNaN}}, {0.0, 0.0}, F::FLOAT64), d.slam[i].stamp, "/scans");
  }
  m.add(cloudOf({kBody}, {0.0}, F::FLOAT64), d.slam[10].stamp + 3.0, "/scans");  // 2 s beyond
  pcl::PCLPointCloud2 c = m.cloud();
  EXPECT_EQ(placeBodyScans(c, d.slam), 1u);
  EXPECT_LT((pointOf(c, 0) - isometry(d.slam[2]) * kBody).norm(), 1e-9);
  EXPECT_TRUE(std::isnan(pointOf(c, 1).x()));
  EXPECT_LT((pointOf(c, 2) - isometry(d.slam[6]) * kBody).norm(), 1e-9);
  EXPECT_LT((pointOf(c, 4) - isometry(d.slam[10]) * kBody).norm(), 1e-9);  // the last pose's
  EXPECT_FALSE(scansInBodyFrame("map", "map", "base_link", "/scans"));
  EXPECT_TRUE(scansInBodyFrame("base_link", "map", "base_link", "/scans"));
  EXPECT_TRUE(scansInBodyFrame("velodyne", "map", "", "/scans"));
  EXPECT_EQ(test::errorOf([] { scansInBodyFrame("velodyne", "map", "base_link", "/scans"); }),
            "/scans: the scans are in frame 'velodyne', neither the poses' ('map': registered "
            "scans) nor their body's ('base_link': scans as the LiDAR saw them)");
}

}  // namespace
}  // namespace flexcloud
