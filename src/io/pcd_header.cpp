#include "flexcloud/io/pcd_header.h"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

#include "flexcloud/types.h"

namespace flexcloud {
namespace {

constexpr std::size_t kMaxHeader = 1 << 16;  // bytes
constexpr std::size_t kMaxFields = 4096;
constexpr std::size_t kMaxCount = 1 << 20;  // elements of one field
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

/// One keyword line of a header: the keyword, its values and its line number.
struct HeaderLine {
  std::size_t line_no = 0;
  std::string key;
  std::vector<std::string> vals;
};

/// The header's keyword lines one by one, comments and blank lines skipped.
class HeaderLines {
 public:
  HeaderLines(const std::string& bytes, const std::string& name) : bytes_(bytes), name_(name) {}
  /// The next keyword line; throws when the bytes end before a DATA line.
  HeaderLine next() {
    while (true) {
      const std::size_t end = bytes_.find('\n', pos_);
      if (end == std::string::npos) {
        fail(name_, 0,
             pos_ == 0 ? "not a PCD file (empty or no header)" : "the PCD header has no DATA line");
      }
      std::string line = bytes_.substr(pos_, end - pos_);
      pos_ = end + 1;
      ++lines_;
      if (pos_ > kMaxHeader) fail(name_, 0, "the PCD header is longer than 64 KiB");
      if (!line.empty() && line.back() == '\r') line.pop_back();
      if (line.empty() || line[0] == '#') continue;
      std::istringstream in(line);
      HeaderLine h;
      h.line_no = lines_;
      in >> h.key;
      for (std::string v; in >> v;) h.vals.push_back(v);
      return h;
    }
  }
  std::size_t offset() const { return pos_; }  ///< the byte after the last line read
  std::size_t lines() const { return lines_; }

 private:
  const std::string& bytes_;
  const std::string& name_;
  std::size_t pos_ = 0;
  std::size_t lines_ = 0;
};

/// The header's keywords as read, before they are checked against each other.
struct RawHeader {
  std::vector<std::string> names;
  std::vector<std::size_t> sizes, counts;
  std::string types;
  bool have_fields = false, have_size = false, have_type = false, have_count = false;
  bool have_width = false, have_points = false;
};

void readSizes(const std::string& name, const HeaderLine& l, RawHeader& raw) {
  raw.sizes.clear();
  for (const auto& v : l.vals) {
    const std::size_t s = parseCount(name, l.line_no, "SIZE", v, 8);
    if (s != 1 && s != 2 && s != 4 && s != 8)
      fail(name, l.line_no, "SIZE " + v + " is not 1, 2, 4 or 8");
    raw.sizes.push_back(s);
  }
  raw.have_size = true;
}

void readTypes(const std::string& name, const HeaderLine& l, RawHeader& raw) {
  raw.types.clear();
  for (const auto& v : l.vals) {
    if (v != "I" && v != "U" && v != "F")
      fail(name, l.line_no, "TYPE '" + v + "' is not I, U or F");
    raw.types.push_back(v[0]);
  }
  raw.have_type = true;
}

void readCounts(const std::string& name, const HeaderLine& l, RawHeader& raw) {
  raw.counts.clear();
  for (const auto& v : l.vals) {
    const std::size_t c = parseCount(name, l.line_no, "COUNT", v, kMaxCount);
    if (c == 0) fail(name, l.line_no, "COUNT 0 is not allowed");
    raw.counts.push_back(c);
  }
  raw.have_count = true;
}

PcdHeader::Data readData(const std::string& name, const HeaderLine& l) {
  if (l.vals.size() != 1) fail(name, l.line_no, "DATA needs one value");
  if (l.vals[0] == "ascii") return PcdHeader::Data::kAscii;
  if (l.vals[0] == "binary") return PcdHeader::Data::kBinary;
  if (l.vals[0] == "binary_compressed") return PcdHeader::Data::kBinaryCompressed;
  fail(name, l.line_no, "DATA '" + l.vals[0] + "' is not ascii, binary or binary_compressed");
}

/// Reads one keyword line into `raw` and `h`; throws for an unknown keyword or a bad value.
void readKeyword(const std::string& name, const HeaderLine& l, RawHeader& raw, PcdHeader& h) {
  const bool first_keyword =
      !raw.have_fields && !raw.have_size && !raw.have_type && !raw.have_width;
  if (l.key == "VERSION") return;
  if (l.key == "FIELDS" || l.key == "COLUMNS") {
    if (l.vals.empty() || l.vals.size() > kMaxFields)
      fail(name, l.line_no, "FIELDS lists no fields");
    raw.names = l.vals;
    raw.have_fields = true;
  } else if (l.key == "SIZE") {
    readSizes(name, l, raw);
  } else if (l.key == "TYPE") {
    readTypes(name, l, raw);
  } else if (l.key == "COUNT") {
    readCounts(name, l, raw);
  } else if (l.key == "WIDTH" || l.key == "HEIGHT" || l.key == "POINTS") {
    if (l.vals.size() != 1) fail(name, l.line_no, l.key + " needs one value");
    const std::size_t v = parseCount(name, l.line_no, l.key, l.vals[0], kMaxPoints);
    if (l.key == "WIDTH") h.width = v, raw.have_width = true;
    if (l.key == "HEIGHT") h.height = v;
    if (l.key == "POINTS") h.points = v, raw.have_points = true;
  } else if (l.key == "VIEWPOINT") {
    if (l.vals.size() != 7) fail(name, l.line_no, "VIEWPOINT needs 7 values");
  } else if (l.key == "DATA") {
    h.data = readData(name, l);
  } else {
    fail(name, l.line_no,
         first_keyword ? "not a PCD file (no PCD header)"
                       : "unknown PCD header keyword '" + l.key + "'");
  }
}

/// Checks that the field lists and the point counts agree and lays the fields out.
void buildFields(const std::string& name, RawHeader& raw, PcdHeader& h) {
  if (!raw.have_fields || !raw.have_size || !raw.have_type || !raw.have_width) {
    fail(name, 0, "the PCD header lacks FIELDS, SIZE, TYPE or WIDTH");
  }
  if (!raw.have_count) raw.counts.assign(raw.names.size(), 1);
  const std::size_t n = raw.names.size();
  if (raw.sizes.size() != n || raw.types.size() != n || raw.counts.size() != n) {
    fail(name, 0,
         "FIELDS, SIZE, TYPE and COUNT list different numbers of fields (" + std::to_string(n) +
             ", " + std::to_string(raw.sizes.size()) + ", " + std::to_string(raw.types.size()) +
             ", " + std::to_string(raw.counts.size()) + ")");
  }
  if (h.height == 0) fail(name, 0, "HEIGHT is 0");
  if (!raw.have_points) h.points = h.width * h.height;
  if (h.width * h.height != h.points) {
    fail(name, 0,
         "WIDTH * HEIGHT (" + std::to_string(h.width) + " * " + std::to_string(h.height) +
             ") is not POINTS (" + std::to_string(h.points) + ")");
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (raw.types[i] == 'F' && raw.sizes[i] != 4 && raw.sizes[i] != 8) {
      fail(name, 0,
           "field " + raw.names[i] + ": a float of " + std::to_string(raw.sizes[i]) + " bytes");
    }
    PcdField f{raw.names[i], raw.sizes[i], raw.types[i], raw.counts[i], h.point_step};
    h.point_step += f.size * f.count;
    h.fields.push_back(f);
  }
}

/// Checks that the body can hold the points the header promises. Nothing is allocated for
/// points a body cannot hold: an ascii point takes at least a character and a separator per
/// value; a compressed body unpacks to at most 4 GiB.
void checkBody(const std::string& name, const PcdHeader& h) {
  const std::uint64_t body = h.file_size >= h.data_offset ? h.file_size - h.data_offset : 0;
  const std::uint64_t bytes = static_cast<std::uint64_t>(h.points) * h.point_step;
  if (h.data == PcdHeader::Data::kBinary && body < bytes) {
    fail(name, 0,
         "the binary body holds " + std::to_string(body) + " bytes, the header promises " +
             std::to_string(bytes) + " (file cut short?)");
  }
  if (h.data == PcdHeader::Data::kBinaryCompressed && h.points > 0 && body < 8) {
    fail(name, 0, "the compressed body is missing (file cut short?)");
  }
  std::uint64_t values = 0;
  for (const auto& f : h.fields) values += f.count;
  if (h.data == PcdHeader::Data::kAscii && h.points > 0 &&
      body + 1 < static_cast<std::uint64_t>(h.points) * 2 * values) {
    fail(name, 0,
         "the ascii body (" + std::to_string(body) + " bytes) cannot hold " +
             std::to_string(h.points) + " points (file cut short?)");
  }
  if (h.data == PcdHeader::Data::kBinaryCompressed && bytes > 0xFFFFFFFFull) {
    fail(name, 0, "POINTS too many for a compressed PCD (more than 4 GiB unpacked)");
  }
}

}  // namespace

PcdHeader parsePcdHeader(const std::string& bytes, const std::string& name,
                         std::uint64_t file_size) {
  PcdHeader h;
  h.file_size = file_size;
  RawHeader raw;
  HeaderLines lines(bytes, name);
  for (HeaderLine l = lines.next();; l = lines.next()) {
    readKeyword(name, l, raw, h);
    if (l.key == "DATA") break;
  }
  h.data_offset = lines.offset();
  h.header_lines = lines.lines();
  buildFields(name, raw, h);
  checkBody(name, h);
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
