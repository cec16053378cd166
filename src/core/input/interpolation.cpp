#include "flexcloud/input/interpolation.h"

#include <algorithm>
#include <cmath>

namespace flexcloud {
namespace {

/// Stamps closer than this are the same instant (text files print stamps with limited digits).
constexpr double kSameStamp = 1e-6;

/// The GNSS point at stamp t from the cubic through the support points (time-parametrised;
/// for four points this is the cubic B-spline that interpolates them).
GnssPoint evaluateCubic(const std::vector<const GnssPoint*>& support, double t) {
  GnssPoint out;
  out.stamp = t;
  out.position.setZero();
  out.std_dev.setZero();
  for (std::size_t i = 0; i < support.size(); ++i) {
    double w = 1.0;
    for (std::size_t j = 0; j < support.size(); ++j) {
      if (j == i) continue;
      w *= (t - support[j]->stamp) / (support[i]->stamp - support[j]->stamp);
    }
    out.position += w * support[i]->position;
    out.std_dev += std::abs(w) * support[i]->std_dev;
  }
  return out;
}

std::optional<GnssPoint> nearest(const std::vector<GnssPoint>& gnss, std::size_t after, double t,
                                 double max_gap) {
  std::size_t best = after;
  if (after == gnss.size() || (after > 0 && t - gnss[after - 1].stamp < gnss[after].stamp - t)) {
    best = after - 1;
  }
  if (std::abs(gnss[best].stamp - t) > 0.5 * max_gap) return std::nullopt;
  GnssPoint p = gnss[best];
  p.stamp = t;
  return p;
}

std::optional<GnssPoint> spline(const std::vector<GnssPoint>& gnss, std::size_t after, double t,
                                const InterpolationOptions& options) {
  // gnss[after - 1].stamp <= t < gnss[after].stamp
  if (after == 0 || after == gnss.size()) return std::nullopt;
  const std::size_t i1 = after - 1;
  const std::size_t i2 = after;
  if (gnss[i2].stamp - gnss[i1].stamp > options.max_gap) return std::nullopt;
  // The outer support points: the nearest ones at least min_spacing away, searched no further
  // than a few gaps in time so a stop-and-go never pulls in GNSS from minutes away.
  const double horizon = 4.0 * options.max_gap + (gnss[i2].stamp - gnss[i1].stamp);
  const GnssPoint* p0 = nullptr;
  for (std::size_t k = i1; k-- > 0;) {
    if (gnss[i1].stamp - gnss[k].stamp > horizon) break;
    if ((gnss[k].position - gnss[i1].position).norm() >= options.min_spacing) {
      p0 = &gnss[k];
      break;
    }
  }
  const GnssPoint* p3 = nullptr;
  for (std::size_t k = i2 + 1; k < gnss.size(); ++k) {
    if (gnss[k].stamp - gnss[i2].stamp > horizon) break;
    if ((gnss[k].position - gnss[i2].position).norm() >= options.min_spacing) {
      p3 = &gnss[k];
      break;
    }
  }
  std::vector<const GnssPoint*> support;
  support.reserve(4);
  if (p0 != nullptr) support.push_back(p0);
  support.push_back(&gnss[i1]);
  support.push_back(&gnss[i2]);
  if (p3 != nullptr) support.push_back(p3);
  return evaluateCubic(support, t);
}

}  // namespace

std::vector<std::optional<GnssPoint>> interpolateGnss(const std::vector<GnssPoint>& gnss,
                                                      const std::vector<double>& stamps,
                                                      const InterpolationOptions& options) {
  std::vector<std::optional<GnssPoint>> out(stamps.size());
  if (gnss.empty()) return out;
  for (std::size_t k = 0; k < stamps.size(); ++k) {
    const double t = stamps[k];
    if (!std::isfinite(t)) continue;
    const auto it = std::upper_bound(gnss.begin(), gnss.end(), t,
                                     [](double v, const GnssPoint& g) { return v < g.stamp; });
    const auto after = static_cast<std::size_t>(it - gnss.begin());
    if (options.mode == InterpolationMode::kNearest) {
      out[k] = nearest(gnss, after, t, options.max_gap);
    } else if (after > 0 && t - gnss[after - 1].stamp <= kSameStamp) {
      out[k] = gnss[after - 1];
      out[k]->stamp = t;
    } else if (after < gnss.size() && gnss[after].stamp - t <= kSameStamp) {
      out[k] = gnss[after];
      out[k]->stamp = t;
    } else {
      out[k] = spline(gnss, after, t, options);
    }
  }
  return out;
}

}  // namespace flexcloud
