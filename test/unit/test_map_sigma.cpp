// The map's expected error by band of distance from the route, against the point sigmas'
// formula at the distances it samples: a straight drive, a sheet that moves nothing.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "flexcloud/uncertainty/map_sigma.h"
#include "test_util.h"

namespace flexcloud {
namespace {

/// A sheet over the box [-100, 400] x [-200, 200] x [-50, 50] that moves every point by `scale`
/// about the origin (1: not at all).
std::shared_ptr<RubberSheet> sheetOver(double scale) {
  return test::scalingSheet({-100.0, -200.0, -50.0}, {400.0, 200.0, 50.0}, {100.0, 3.0, 1.0},
                            scale);
}

/// 300 poses 1 m apart along x, and their sigmas (5 cm, 10 cm).
Trajectory straightDrive(PoseSigmas& sigmas) {
  Trajectory t(300);
  for (std::size_t i = 0; i < t.size(); ++i) {
    t[i].stamp = 0.1 * static_cast<double>(i);
    t[i].position = {static_cast<double>(i), 0.0, 0.0};
    sigmas.h.push_back(0.05), sigmas.v.push_back(0.1);
  }
  return t;
}

// The bands' points lie at 4 distances each (1.25-8.75, 12.5-27.5, 32.5-47.5 m), both sides: the
// root mean square over the four, the median the sigma at the second distance, the 95th
// percentile at the fourth, as the formula gives them (pose, scatter, heading times the distance;
// vertically tilt times the distance).
TEST(MapSigma, BandsOfAStraightDriveAgainstTheFormula) {
  PoseSigmas sigmas;
  const Trajectory drive = straightDrive(sigmas);
  const PointSigmaModel model;  // 2 cm scatter, 4 mrad heading, 2 mrad tilt
  const MapSigma m = expectedMapSigma(drive, drive, sigmas, *sheetOver(1.0), model);
  const auto h = [&](double r) {
    return std::sqrt(0.05 * 0.05 + 0.02 * 0.02 + std::pow(model.heading * r, 2));
  };
  const auto v = [&](double r) {
    return std::sqrt(0.1 * 0.1 + 0.02 * 0.02 + std::pow(model.tilt * r, 2));
  };
  const double median_at[] = {3.75, 17.5, 37.5}, p95_at[] = {8.75, 27.5, 47.5};
  for (int b = 0; b < kMapSigmaBands; ++b) {
    double h2 = 0.0, v2 = 0.0;  // the root mean square over the band's four distances
    for (int k = 0; k < 4; ++k) {
      const double r = kMapSigmaBandEdges[b] +
                       (kMapSigmaBandEdges[b + 1] - kMapSigmaBandEdges[b]) * (k + 0.5) / 4.0;
      h2 += h(r) * h(r) / 4.0, v2 += v(r) * v(r) / 4.0;
    }
    EXPECT_NEAR(m.sheet[b].h_rms, std::sqrt(h2), 2e-4) << "band " << b;
    EXPECT_NEAR(m.sheet[b].h_median, h(median_at[b]), 2e-4) << "band " << b;
    EXPECT_NEAR(m.sheet[b].h_p95, h(p95_at[b]), 2e-4) << "band " << b;
    EXPECT_NEAR(m.sheet[b].v_rms, std::sqrt(v2), 2e-4) << "band " << b;
    EXPECT_NEAR(m.own_pose[b].h_rms, m.sheet[b].h_rms, 2e-4) << "band " << b;
  }
  EXPECT_GT(m.sheet[2].h_median, 0.15);  // 4 mrad at 37.5 m alone: 0.15 m
}

// A sheet that stretches the map by 1 % adds its strain to the sheet's points, not to points
// moved with their own pose; without sigmas nothing is known (NaN).
TEST(MapSigma, TheSheetsStrainAndUnknownPoses) {
  PoseSigmas sigmas;
  const Trajectory drive = straightDrive(sigmas);
  const auto stretched = sheetOver(1.01);
  Trajectory moved = drive;
  for (auto& p : moved) p.position *= 1.01;
  const MapSigma m = expectedMapSigma(drive, moved, sigmas, *stretched, PointSigmaModel{});
  for (int b = 0; b < kMapSigmaBands; ++b) {
    EXPECT_GT(m.sheet[b].h_median, m.own_pose[b].h_median + 0.01) << "band " << b;
  }
  const MapSigma none = expectedMapSigma(drive, drive, PoseSigmas{}, *sheetOver(1.0), {});
  EXPECT_TRUE(std::isnan(none.sheet[0].h_median));
  EXPECT_TRUE(std::isnan(none.own_pose[2].h_p95));
}

}  // namespace
}  // namespace flexcloud
