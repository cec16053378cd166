#include "flexcloud/io/pcd_header.h"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

#include "flexcloud/types.h"

namespace flexcloud {
namespace {

constexpr std::size_t kMaxHeader = 1 << 16;     // bytes
constexpr std::size_t kMaxFields = 4096;
constexpr std::size_t kMaxCount = 1 << 20;      // elements of one field
constexpr std::uint64_t kMaxPoints = 1ull << 36;

[[noreturn]] void fail(const std::string& name, std::size_t line, const std::string& what) {
  throw Error(name + (line ? ":" + std::to_string(line) : "") + ": " + what);
}

std::size_t parseCount(const std::string& name, std::size_t line, const std::string& key,
                       const std::string& tok, std::uint64_t max) {
  if (tok.empty() || tok.find_first_not_of("0123456789") != std::string::npos || tok.size() > 18) {
    fail(name, line, key + " '" + tok + "' is not a whole number");
  }
  const std::uint64_t v = std::stoull(tok);
  if (v > max) fail(name, line, key + " " + tok + " is too large");
  return static_cast<std::size_t>(v);
}

}  // namespace

PcdHeader parsePcdHeader(const std::string& bytes, const std::string& name,
                         std::uint64_t file_size) {
  PcdHeader h;
  h.file_size = file_size;
  std::vector<std::string> names;
  std::vector<std::size_t> sizes, counts;
  std::string types;
  bool have_fields = false, have_size = false, have_type = false, have_count = false;
  bool have_width = false, have_points = false, have_data = false;
  std::size_t pos = 0;
  std::size_t line_no = 0;
  while (!have_data) {
    const std::size_t end = bytes.find('\n', pos);
    if (end == std::string::npos) {
      fail(name, 0, pos == 0 ? "not a PCD file (empty or no header)"
                             : "the PCD header has no DATA line");
    }
    std::string line = bytes.substr(pos, end - pos);
    pos = end + 1;
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    std::istringstream in(line);
    std::string key;
    in >> key;
    std::vector<std::string> vals;
    for (std::string v; in >> v;) vals.push_back(v);
    const bool first_keyword = !have_fields && !have_size && !have_type && !have_width;
    if (key == "VERSION") {
      continue;
    } else if (key == "FIELDS" || key == "COLUMNS") {
      if (vals.empty() || vals.size() > kMaxFields) fail(name, line_no, "FIELDS lists no fields");
      names = vals;
      have_fields = true;
    } else if (key == "SIZE") {
      sizes.clear();
      for (const auto& v : vals) {
        const std::size_t s = parseCount(name, line_no, "SIZE", v, 8);
        if (s != 1 && s != 2 && s != 4 && s != 8) fail(name, line_no, "SIZE " + v + " is not 1, 2, 4 or 8");
        sizes.push_back(s);
      }
      have_size = true;
    } else if (key == "TYPE") {
      types.clear();
      for (const auto& v : vals) {
        if (v != "I" && v != "U" && v != "F") fail(name, line_no, "TYPE '" + v + "' is not I, U or F");
        types.push_back(v[0]);
      }
      have_type = true;
    } else if (key == "COUNT") {
      counts.clear();
      for (const auto& v : vals) {
        const std::size_t c = parseCount(name, line_no, "COUNT", v, kMaxCount);
        if (c == 0) fail(name, line_no, "COUNT 0 is not allowed");
        counts.push_back(c);
      }
      have_count = true;
    } else if (key == "WIDTH" || key == "HEIGHT" || key == "POINTS") {
      if (vals.size() != 1) fail(name, line_no, key + " needs one value");
      const std::size_t v = parseCount(name, line_no, key, vals[0], kMaxPoints);
      if (key == "WIDTH") h.width = v, have_width = true;
      if (key == "HEIGHT") h.height = v;
      if (key == "POINTS") h.points = v, have_points = true;
    } else if (key == "VIEWPOINT") {
      if (vals.size() != 7) fail(name, line_no, "VIEWPOINT needs 7 values");
    } else if (key == "DATA") {
      if (vals.size() != 1) fail(name, line_no, "DATA needs one value");
      if (vals[0] == "ascii") h.data = PcdHeader::Data::kAscii;
      else if (vals[0] == "binary") h.data = PcdHeader::Data::kBinary;
      else if (vals[0] == "binary_compressed") h.data = PcdHeader::Data::kBinaryCompressed;
      else fail(name, line_no, "DATA '" + vals[0] + "' is not ascii, binary or binary_compressed");
      have_data = true;
    } else {
      fail(name, line_no, first_keyword ? "not a PCD file (no PCD header)"
                                        : "unknown PCD header keyword '" + key + "'");
    }
    if (pos > kMaxHeader) fail(name, 0, "the PCD header is longer than 64 KiB");
  }
  if (!have_fields || !have_size || !have_type || !have_width) {
    fail(name, 0, "the PCD header lacks FIELDS, SIZE, TYPE or WIDTH");
  }
  if (!have_count) counts.assign(names.size(), 1);
  if (sizes.size() != names.size() || types.size() != names.size() ||
      counts.size() != names.size()) {
    fail(name, 0, "FIELDS, SIZE, TYPE and COUNT list different numbers of fields (" +
                      std::to_string(names.size()) + ", " + std::to_string(sizes.size()) + ", " +
                      std::to_string(types.size()) + ", " + std::to_string(counts.size()) + ")");
  }
  if (h.height == 0) fail(name, 0, "HEIGHT is 0");
  if (!have_points) h.points = h.width * h.height;
  if (h.width * h.height != h.points) {
    fail(name, 0, "WIDTH * HEIGHT (" + std::to_string(h.width) + " * " + std::to_string(h.height) +
                      ") is not POINTS (" + std::to_string(h.points) + ")");
  }
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (types[i] == 'F' && sizes[i] != 4 && sizes[i] != 8) {
      fail(name, 0, "field " + names[i] + ": a float of " + std::to_string(sizes[i]) + " bytes");
    }
    PcdField f{names[i], sizes[i], types[i], counts[i], h.point_step};
    h.point_step += f.size * f.count;
    h.fields.push_back(f);
  }
  h.data_offset = pos;
  h.header_lines = line_no;
  const std::uint64_t body = file_size >= pos ? file_size - pos : 0;
  if (h.data == PcdHeader::Data::kBinary &&
      body < static_cast<std::uint64_t>(h.points) * h.point_step) {
    fail(name, 0, "the binary body holds " + std::to_string(body) + " bytes, the header promises " +
                      std::to_string(static_cast<std::uint64_t>(h.points) * h.point_step) +
                      " (file cut short?)");
  }
  if (h.data == PcdHeader::Data::kBinaryCompressed && h.points > 0 && body < 8) {
    fail(name, 0, "the compressed body is missing (file cut short?)");
  }
  // Nothing is allocated for points a body cannot hold: an ascii point takes at least a
  // character and a separator per value; a compressed body unpacks to at most 4 GiB.
  std::uint64_t values = 0;
  for (const auto& f : h.fields) values += f.count;
  if (h.data == PcdHeader::Data::kAscii && h.points > 0 &&
      body + 1 < static_cast<std::uint64_t>(h.points) * 2 * values) {
    fail(name, 0, "the ascii body (" + std::to_string(body) + " bytes) cannot hold " +
                      std::to_string(h.points) + " points (file cut short?)");
  }
  if (h.data == PcdHeader::Data::kBinaryCompressed &&
      static_cast<std::uint64_t>(h.points) * h.point_step > 0xFFFFFFFFull) {
    fail(name, 0, "POINTS too many for a compressed PCD (more than 4 GiB unpacked)");
  }
  return h;
}

PcdHeader readPcdHeader(const std::string& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) throw Error(path + ": cannot open: " + std::strerror(errno));
  const std::uint64_t size = static_cast<std::uint64_t>(in.tellg());
  in.seekg(0);
  std::string head(static_cast<std::size_t>(std::min<std::uint64_t>(size, kMaxHeader + 1)), '\0');
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<std::size_t>(in.gcount()));
  return parsePcdHeader(head, path, size);
}

}  // namespace flexcloud
