#include "flexcloud/io/param_table.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <sstream>

namespace flexcloud {

std::vector<ParamRef> paramRefs(Params& p) {
  using K = ParamRef::Kind;
  auto d = [](const char* n, double& v) { return ParamRef{n, K::kDouble, &v, nullptr, nullptr}; };
  auto i = [](const char* n, int& v) { return ParamRef{n, K::kInt, nullptr, &v, nullptr}; };
  return {
      d("datum_lat", p.datum_lat),
      d("datum_lon", p.datum_lon),
      d("datum_alt", p.datum_alt),
      d("default_std_dev", p.default_std_dev),
      d("gnss_time_offset", p.gnss_time_offset),
      d("max_gnss_speed", p.max_gnss_speed),
      ParamRef{"interpolation", K::kInterpolation, nullptr, nullptr, &p.interpolation},
      d("min_spacing", p.min_spacing),
      d("max_gap", p.max_gap),
      i("control_points", p.control_points),
      d("refine_fraction", p.refine_fraction),
      d("stddev_threshold", p.stddev_threshold),
      d("margin_x", p.margin_x),
      d("margin_y", p.margin_y),
      d("margin_z", p.margin_z),
      d("margin_min", p.margin_min),
      i("threads", p.threads),
  };
}

namespace {

double parseDouble(const std::string& name, const std::string& text) {
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || errno == ERANGE) {
    throw Error(name + ": '" + text + "' is not a number");
  }
  return v;
}

}  // namespace

void setParam(Params& p, const std::string& name, const std::string& value) {
  if (name == "excluded_ranges") {
    p.excluded_ranges = parseRanges(value);
    return;
  }
  for (auto& ref : paramRefs(p)) {
    if (ref.name != name) continue;
    switch (ref.kind) {
      case ParamRef::Kind::kDouble:
        *ref.d = parseDouble(name, value);
        return;
      case ParamRef::Kind::kInt: {
        const double v = parseDouble(name, value);
        if (v != std::floor(v) || std::abs(v) > 2e9) {
          throw Error(name + ": '" + value + "' is not an integer");
        }
        *ref.i = static_cast<int>(v);
        return;
      }
      case ParamRef::Kind::kInterpolation:
        *ref.mode = parseInterpolationMode(value);
        return;
    }
  }
  throw Error("unknown parameter '" + name + "'");
}

std::vector<TimeRange> parseRanges(const std::string& text) {
  std::vector<TimeRange> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    if (item.empty()) continue;
    const auto colon = item.find(':');
    if (colon == std::string::npos) {
      throw Error("excluded_ranges: '" + item + "' is not begin:end (seconds)");
    }
    out.push_back({parseDouble("excluded_ranges", item.substr(0, colon)),
                   parseDouble("excluded_ranges", item.substr(colon + 1))});
  }
  return out;
}

}  // namespace flexcloud
