#include "flexcloud/io/text_io.h"

#include <algorithm>
#include <array>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <optional>
#include <sstream>
#include <utility>

namespace flexcloud {
namespace {

struct Table {
  std::vector<std::vector<double>> rows;
  std::vector<double> stamps;  // in seconds after unit resolution
};

[[noreturn]] void fail(const std::string& name, std::size_t line, const std::string& what) {
  throw Error(name + ":" + std::to_string(line) + ": " + what);
}

/// The tokens of one line: commas, tabs and carriage returns count as spaces.
std::vector<std::string> tokensOf(std::string line) {
  for (char& c : line) {
    if (c == ',' || c == '\t' || c == '\r' || c == ';') c = ' ';
  }
  std::istringstream fields(line);
  std::vector<std::string> tokens;
  std::string tok;
  while (fields >> tok) tokens.push_back(tok);
  return tokens;
}

/// The number a whole token spells; nullopt where it is not one.
std::optional<double> numberOf(const std::string& tk) {
  char* end = nullptr;
  const double v = std::strtod(tk.c_str(), &end);
  if (end == tk.c_str() || *end != '\0') return std::nullopt;
  return v;
}

/// The unit of a file's stamps by their size (kAuto): Unix time in s stays below 1e10 until
/// the year 2286; in ms it is above 1e12, in us above 1e15, in ns above 1e18 (as integers or
/// written as floats). Stamps counted from 0 read as seconds; give the unit for those.
StampUnit detectUnit(const std::vector<std::vector<double>>& rows) {
  double largest = 0.0;
  for (const auto& r : rows) {
    if (std::isfinite(r[0])) largest = std::max(largest, std::abs(r[0]));
  }
  if (largest > 1e16) return StampUnit::kNanoseconds;
  if (largest > 1e13) return StampUnit::kMicroseconds;
  if (largest > 1e10) return StampUnit::kMilliseconds;
  return StampUnit::kSeconds;
}

/// A stamp in seconds from its text in `unit`: integers are split into whole seconds and the
/// rest, so 19-digit nanosecond stamps keep their sub-microsecond part.
double stampSeconds(const std::string& text, double value, StampUnit unit) {
  const long long per_second = unit == StampUnit::kNanoseconds    ? 1000000000LL
                               : unit == StampUnit::kMicroseconds ? 1000000LL
                               : unit == StampUnit::kMilliseconds ? 1000LL
                                                                  : 1LL;
  if (per_second == 1) return value;
  const bool integer =
      text.find_first_not_of("+-0123456789") == std::string::npos && std::abs(value) < 9e18;
  if (!integer) return value / static_cast<double>(per_second);
  const long long v = std::strtoll(text.c_str(), nullptr, 10);
  return static_cast<double>(v / per_second) +
         static_cast<double>(v % per_second) / static_cast<double>(per_second);
}

/// Splits every data line into numbers; the first column is the stamp, kept as text for the
/// unit decision. A first line that is not numbers is a header (stamp,lat,lon,...) and skipped.
Table parseTable(const std::string& text, const std::string& name,
                 const std::vector<std::size_t>& columns, const std::string& layout,
                 StampUnit unit) {
  Table t;
  std::vector<std::string> stamp_text;
  // A byte order mark (editors on Windows write one) is not part of the first line.
  const std::string bom = "\xEF\xBB\xBF";
  std::istringstream in(text.compare(0, bom.size(), bom) == 0 ? text.substr(bom.size()) : text);
  std::string line;
  std::size_t line_no = 0;
  bool header_allowed = true;
  while (std::getline(in, line)) {
    ++line_no;
    const std::vector<std::string> tokens = tokensOf(line);
    if (tokens.empty() || tokens[0][0] == '#') continue;
    if (std::exchange(header_allowed, false) && !numberOf(tokens[0])) continue;
    if (std::find(columns.begin(), columns.end(), tokens.size()) == columns.end()) {
      std::string counts;
      for (std::size_t c : columns) counts += (counts.empty() ? "" : " or ") + std::to_string(c);
      fail(name, line_no,
           "expected " + layout + " (" + counts + " columns), found " +
               std::to_string(tokens.size()));
    }
    std::vector<double> row;
    row.reserve(tokens.size());
    for (const auto& tk : tokens) {
      const std::optional<double> v = numberOf(tk);
      if (!v) fail(name, line_no, "'" + tk + "' is not a number");
      row.push_back(*v);
    }
    stamp_text.push_back(tokens[0]);
    t.rows.push_back(std::move(row));
  }
  const StampUnit resolved = unit == StampUnit::kAuto ? detectUnit(t.rows) : unit;
  t.stamps.reserve(t.rows.size());
  for (std::size_t i = 0; i < t.rows.size(); ++i) {
    t.stamps.push_back(stampSeconds(stamp_text[i], t.rows[i][0], resolved));
  }
  return t;
}

}  // namespace

StampUnit parseStampUnit(const std::string& text) {
  if (text == "auto") return StampUnit::kAuto;
  if (text == "s") return StampUnit::kSeconds;
  if (text == "ms") return StampUnit::kMilliseconds;
  if (text == "us") return StampUnit::kMicroseconds;
  if (text == "ns") return StampUnit::kNanoseconds;
  throw Error("stamp unit: '" + text + "' is not one of auto, s, ms, us, ns");
}

std::string readWholeFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": cannot open: " + std::strerror(errno));
  std::ostringstream s;
  s << in.rdbuf();
  if (in.bad()) throw Error(path + ": read error");
  return s.str();
}

namespace {

/// One T per row of `t`, made by make(stamp in seconds, row).
template <typename T, typename Make>
std::vector<T> fromRows(const Table& t, Make make) {
  std::vector<T> out;
  out.reserve(t.rows.size());
  for (std::size_t i = 0; i < t.rows.size(); ++i) out.push_back(make(t.stamps[i], t.rows[i]));
  return out;
}

/// Columns 4-6 of a seven-column row: the std-devs; NaN (unknown) in a four-column row.
Eigen::Vector3d stdColumns(const std::vector<double>& r) {
  return r.size() == 7 ? Eigen::Vector3d(r[4], r[5], r[6])
                       : Eigen::Vector3d::Constant(std::nan(""));
}

}  // namespace

Trajectory parseTum(const std::string& text, const std::string& name, StampUnit unit) {
  const Table t = parseTable(text, name, {8}, "stamp x y z qx qy qz qw", unit);
  return fromRows<Pose>(t, [](double stamp, const std::vector<double>& r) {
    Pose p;
    p.stamp = stamp;
    p.position = Eigen::Vector3d(r[1], r[2], r[3]);
    p.orientation.coeffs() << r[4], r[5], r[6], r[7];  // x y z w
    return p;
  });
}

std::vector<RawFix> parseGeodeticGnss(const std::string& text, const std::string& name,
                                      StampUnit unit) {
  const Table t = parseTable(text, name, {4, 7}, "stamp lat lon alt [std_e std_n std_u]", unit);
  return fromRows<RawFix>(t, [](double stamp, const std::vector<double>& r) {
    RawFix f;
    f.fix = GeoFix{stamp, r[1], r[2], r[3], stdColumns(r)};
    return f;
  });
}

std::vector<GnssPoint> parseLocalGnss(const std::string& text, const std::string& name,
                                      StampUnit unit) {
  const Table t = parseTable(text, name, {4, 7}, "stamp x y z [sx sy sz]", unit);
  return fromRows<GnssPoint>(t, [](double stamp, const std::vector<double>& r) {
    GnssPoint g;
    g.stamp = stamp;
    g.position = Eigen::Vector3d(r[1], r[2], r[3]);
    g.std_dev = stdColumns(r);
    return g;
  });
}

Trajectory readTumFile(const std::string& path, StampUnit unit) {
  return parseTum(readWholeFile(path), path, unit);
}

std::vector<RawFix> readGeodeticGnssFile(const std::string& path, StampUnit unit) {
  return parseGeodeticGnss(readWholeFile(path), path, unit);
}

std::vector<GnssPoint> readLocalGnssFile(const std::string& path, StampUnit unit) {
  return parseLocalGnss(readWholeFile(path), path, unit);
}

std::vector<Eigen::Vector3d> readPointsFile(const std::string& path) {
  const Table t = parseTable(readWholeFile(path), path, {3}, "x y z", StampUnit::kSeconds);
  std::vector<Eigen::Vector3d> out;
  out.reserve(t.rows.size());
  for (const auto& r : t.rows) {
    out.emplace_back(r[0], r[1], r[2]);
    if (!out.back().allFinite()) {
      throw Error(path + ": point " + std::to_string(out.size()) + " is not finite");
    }
  }
  return out;
}

void appendFixed(std::string& s, double v, int decimals) {
  // The longest fixed text of a double: 309 integer digits, a sign, a point, the decimals.
  std::array<char, 320 + 32> buf;
  decimals = std::clamp(decimals, 0, 32);
#if defined(__cpp_lib_to_chars)
  const auto r =
      std::to_chars(buf.data(), buf.data() + buf.size(), v, std::chars_format::fixed, decimals);
  s.append(buf.data(), r.ptr);
#else
  // libstdc++ before GCC 11 has no to_chars for double: printf rounds the same, exactly
  // (TextIo's unit test holds to_chars to printf's digits on every value it writes).
  const int n = std::snprintf(buf.data(), buf.size(), "%.*f", decimals, v);
  s.append(buf.data(),
           static_cast<std::size_t>(std::clamp(n, 0, static_cast<int>(buf.size()) - 1)));
#endif
}

std::string formatTum(const Trajectory& poses) {
  std::string s;
  s.reserve(poses.size() * 112);
  for (const auto& p : poses) {
    appendFixed(s, p.stamp, 9);
    for (int a = 0; a < 3; ++a) {
      s += ' ';
      appendFixed(s, p.position(a), 6);
    }
    for (int c = 0; c < 4; ++c) {  // x, y, z, w
      s += ' ';
      appendFixed(s, p.orientation.coeffs()(c), 9);
    }
    s += '\n';
  }
  return s;
}

}  // namespace flexcloud
