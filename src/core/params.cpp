#include "flexcloud/params.h"

#include <cmath>
#include <sstream>

namespace flexcloud {

std::string toString(InterpolationMode mode) {
  return mode == InterpolationMode::kSpline ? "spline" : "nearest";
}

InterpolationMode parseInterpolationMode(const std::string& text) {
  if (text == "spline") return InterpolationMode::kSpline;
  if (text == "nearest") return InterpolationMode::kNearest;
  throw Error("interpolation: '" + text + "' is not one of spline, nearest");
}

namespace {

class Problems {
 public:
  void require(bool ok, const std::string& what) {
    if (ok) return;
    if (!text_.empty()) text_ += "; ";
    text_ += what;
  }
  const std::string& text() const { return text_; }

 private:
  std::string text_;
};

std::string num(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

bool inRange(double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; }

}  // namespace

bool Params::hasDatum() const {
  return std::isfinite(datum_lat) && std::isfinite(datum_lon) && std::isfinite(datum_alt);
}

std::string Params::validate() const {
  Problems p;
  const bool none = std::isnan(datum_lat) && std::isnan(datum_lon) && std::isnan(datum_alt);
  p.require(none || hasDatum(), "datum_lat, datum_lon, datum_alt: give all three or none");
  if (hasDatum()) {
    p.require(inRange(datum_lat, -90, 90), "datum_lat " + num(datum_lat) + " is not in [-90, 90]");
    p.require(inRange(datum_lon, -180, 180),
              "datum_lon " + num(datum_lon) + " is not in [-180, 180]");
    p.require(inRange(datum_alt, -11000, 100000),
              "datum_alt " + num(datum_alt) + " m is not in [-11000, 100000]");
  }
  p.require(inRange(default_std_dev, 0, 1000),
            "default_std_dev " + num(default_std_dev) + " m is not in [0, 1000]");
  p.require(inRange(gnss_time_offset, -86400, 86400),
            "gnss_time_offset " + num(gnss_time_offset) + " s is not in [-86400, 86400]");
  p.require(inRange(max_gnss_speed, 0.1, 10000),
            "max_gnss_speed " + num(max_gnss_speed) + " m/s is not in [0.1, 10000]");
  p.require(inRange(min_spacing, 0, 1000),
            "min_spacing " + num(min_spacing) + " m is not in [0, 1000]");
  p.require(inRange(max_gap, 1e-3, 3600), "max_gap " + num(max_gap) + " s is not in [0.001, 3600]");
  p.require(control_points >= 4 && control_points <= 1000000,
            "control_points " + std::to_string(control_points) + " is not in [4, 1000000]");
  p.require(inRange(stddev_threshold, 1e-6, 1000),
            "stddev_threshold " + num(stddev_threshold) + " m is not in [1e-6, 1000]");
  p.require(inRange(refine_fraction, 0, 1),
            "refine_fraction " + num(refine_fraction) + " is not in [0, 1]");
  for (const auto& r : excluded_ranges) {
    p.require(std::isfinite(r.begin) && std::isfinite(r.end) && r.begin <= r.end,
              "excluded_ranges [" + num(r.begin) + ", " + num(r.end) +
                  "] is not a finite range with begin <= end");
  }
  for (auto [name, v] : {std::pair{"margin_x", margin_x}, {"margin_y", margin_y},
                         {"margin_z", margin_z}}) {
    p.require(inRange(v, 0, 1000), std::string(name) + " " + num(v) + " is not in [0, 1000]");
  }
  p.require(inRange(margin_min, 0.01, 1e6),
            "margin_min " + num(margin_min) + " m is not in [0.01, 1e6]");
  p.require(threads >= 0 && threads <= 1024,
            "threads " + std::to_string(threads) + " is not in [0, 1024]");
  return p.text();
}

}  // namespace flexcloud
