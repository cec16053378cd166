#include "flexcloud/param_table.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>

namespace flexcloud {
namespace {

std::string num(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

double parseNumber(const std::string& name, const std::string& text) {
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || errno == ERANGE) {
    throw Error(name + ": '" + text + "' is not a number");
  }
  return v;
}

}  // namespace

std::vector<TimeRange> parseTimeRanges(const std::string& name, const std::string& text) {
  std::vector<TimeRange> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    if (item.empty()) continue;
    const auto colon = item.find(':');
    if (colon == std::string::npos) {
      throw Error(name + ": '" + item + "' is not begin:end (seconds)");
    }
    out.push_back(
        {parseNumber(name, item.substr(0, colon)), parseNumber(name, item.substr(colon + 1))});
  }
  return out;
}

namespace {

std::string joined(const std::vector<std::string>& words) {
  std::string out;
  for (const auto& w : words) out += (out.empty() ? "" : ", ") + w;
  return out;
}

}  // namespace

std::string typeName(ParamType type) {
  switch (type) {
    case ParamType::kReal:
      return "double";
    case ParamType::kInt:
      return "int";
    case ParamType::kBool:
      return "bool";
    case ParamType::kText:
    case ParamType::kChoice:
      return "str";
    case ParamType::kRanges:
      return "ranges";
  }
  return "?";
}

std::string checkValue(const ParamSpec& spec, const ParamValue& v) {
  const std::string unit = spec.unit.empty() ? "" : " " + spec.unit;
  switch (spec.type) {
    case ParamType::kReal:
    case ParamType::kInt:
      if (spec.nan_unset && std::isnan(v.number)) return "";
      if (std::isfinite(v.number) && v.number >= spec.min && v.number <= spec.max) return "";
      return spec.name + " " + num(v.number) + unit + " is not in [" + num(spec.min) + ", " +
             num(spec.max) + "]";
    case ParamType::kChoice:
      for (const auto& c : spec.choices) {
        if (c == v.text) return "";
      }
      return spec.name + " '" + v.text + "' is not one of " + joined(spec.choices);
    case ParamType::kRanges:
      for (const auto& r : v.ranges) {
        if (!(std::isfinite(r.begin) && std::isfinite(r.end) && r.begin <= r.end)) {
          return spec.name + " [" + num(r.begin) + ", " + num(r.end) +
                 "] is not a finite range with begin <= end";
        }
      }
      return "";
    case ParamType::kBool:
    case ParamType::kText:
      return "";
  }
  return "";
}

ParamValue parseValue(const ParamSpec& spec, const std::string& text) {
  ParamValue v;
  switch (spec.type) {
    case ParamType::kReal:
      v.number = parseNumber(spec.name, text);
      break;
    case ParamType::kInt:
      v.number = parseNumber(spec.name, text);
      if (v.number != std::floor(v.number) || std::abs(v.number) > 2e9) {
        throw Error(spec.name + ": '" + text + "' is not an integer");
      }
      break;
    case ParamType::kBool:
      if (text == "true" || text == "1") {
        v.number = 1.0;
      } else if (text != "false" && text != "0") {
        throw Error(spec.name + ": '" + text + "' is not true or false");
      }
      break;
    case ParamType::kChoice:  // checked by validate(), or by the field's own parser
    case ParamType::kText:
      v.text = text;
      break;
    case ParamType::kRanges:
      v.ranges = parseTimeRanges(spec.name, text);
      break;
  }
  return v;
}

std::string formatValue(const ParamSpec& spec, const ParamValue& v) {
  switch (spec.type) {
    case ParamType::kReal: {
      // The shortest text that reads back as the same double.
      char buf[32];
      for (int digits = 15; digits <= 17; ++digits) {
        std::snprintf(buf, sizeof(buf), "%.*g", digits, v.number);
        if (std::strtod(buf, nullptr) == v.number) break;
      }
      return buf;
    }
    case ParamType::kInt:
      return std::to_string(static_cast<long long>(v.number));
    case ParamType::kBool:
      return v.number != 0.0 ? "true" : "false";
    case ParamType::kText:
    case ParamType::kChoice:
      return v.text;
    case ParamType::kRanges: {
      std::string out;
      for (const auto& r : v.ranges) {
        out += (out.empty() ? "" : ",") + num(r.begin) + ":" + num(r.end);
      }
      return out;
    }
  }
  return "";
}

}  // namespace flexcloud
