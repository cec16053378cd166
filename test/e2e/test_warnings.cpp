// The warnings on stretches of GNSS the fusion left out, judged against the simulator's truth:
// a stretch is said to have claimed RTK precision only where its std-devs came with the fixes,
// and the GNSS of every stretch named is truly off (the fusion left out erring fixes, not good
// ones).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <string>
#include <utility>
#include <vector>

#include "flexcloud/georeference.h"
#include "flexcloud/sim/scenarios.h"
#include "test_util.h"

namespace flexcloud {
namespace {

using Span = std::pair<double, double>;

/// The spans (s) of the warnings that name a stretch of GNSS ("GNSS from A to B s ...") and
/// contain `kind`.
std::vector<Span> stretches(const std::vector<std::string>& warnings, const std::string& kind) {
  std::vector<Span> out;
  for (const auto& w : warnings) {
    if (w.rfind("GNSS from ", 0) != 0 || w.find(kind) == std::string::npos) continue;
    char* end = nullptr;
    const double a = std::strtod(w.c_str() + 10, &end);
    const double b = std::strtod(end + 4, nullptr);  // past " to "
    out.emplace_back(a, b);
  }
  return out;
}

/// The true position at stamp t, linear between the two true poses around it.
Eigen::Vector3d truthAt(const Trajectory& truth, double t) {
  const auto it = std::lower_bound(truth.begin(), truth.end(), t,
                                   [](const Pose& p, double s) { return p.stamp < s; });
  if (it == truth.begin()) return truth.front().position;
  if (it == truth.end()) return truth.back().position;
  const Pose& a = *(it - 1);
  const double f = (t - a.stamp) / (it->stamp - a.stamp);
  return a.position + f * (it->position - a.position);
}

/// Median distance from the truth of the fixes the fusion left out within `s` (the drives here
/// have no clock offset and no lever arm: a fix's place is the truth's at its stamp).
double medianTrueError(const GeoreferenceResult& r, const Trajectory& truth, const Span& s) {
  std::vector<double> e;
  for (const FixOutcome& f : r.fusion->fixes) {
    if (f.verdict != FixVerdict::kOutlier || f.stamp < s.first || f.stamp > s.second) continue;
    e.push_back((f.position - truthAt(truth, f.stamp)).norm());
  }
  if (e.empty()) return 0.0;
  std::nth_element(e.begin(), e.begin() + static_cast<std::ptrdiff_t>(e.size() / 2), e.end());
  return e[e.size() / 2];
}

/// Runs `scenario` and checks the stretches its warnings name: `claimed` of them say their
/// std-devs claimed RTK precision (or none do), the others that no std-dev was given; the GNSS
/// of each is off the truth by half a metre or more in the median.
void checkStretches(const char* scenario, bool claimed) {
  for (std::uint64_t seed : {1, 2, 3}) {
    const sim::SimDrive d = sim::simulateDrive(sim::scenario(scenario, seed, 1000));
    const GeoreferenceResult r = georeference(test::inputOf(d), test::atSimDatum(d));
    ASSERT_TRUE(r.fusion.has_value());
    const std::vector<std::string> w = resultWarnings(r, Params{}, nullptr);
    const std::vector<Span> rtk = stretches(w, "claimed RTK precision");
    const std::vector<Span> unknown = stretches(w, "no std-dev given");
    EXPECT_EQ(rtk.empty(), !claimed) << scenario << " seed " << seed;
    EXPECT_EQ(unknown.empty(), claimed) << scenario << " seed " << seed;
    for (const Span& s : claimed ? rtk : unknown) {
      const double e = medianTrueError(r, d.truth, s);
      std::printf(
          "%s seed %lu: stretch %.1f-%.1f s named, its left-out fixes %.2f m off the truth\n",
          scenario, static_cast<unsigned long>(seed), s.first - d.truth.front().stamp,
          s.second - d.truth.front().stamp, e);
      EXPECT_GT(e, 0.5) << scenario << " seed " << seed << " " << s.first;
    }
  }
}

/// Urban GNSS whose receiver reports std-devs, multipath claiming RTK among it, and a drive that
/// ends in false RTK fixes: the stretches left out are named as claiming RTK precision.
TEST(Warnings, StretchesThatClaimedRtkPrecisionAreNamedSo) {
  checkStretches("open_urban_end", true);
}

/// The same urban GNSS without any covariance: nothing was claimed, and the warnings say so.
TEST(Warnings, StretchesWithoutAStdDevClaimNothing) { checkStretches("loop_urban_nocov", false); }

}  // namespace
}  // namespace flexcloud
