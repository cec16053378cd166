#include "flexcloud/io/pcd_io.h"

#include <pcl/io/lzf.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>

#include "flexcloud/io/pcd_header.h"
#include "flexcloud/io/pcd_stream.h"
#include "flexcloud/types.h"

namespace flexcloud {
namespace {

// PCL's own reader trusts the file: a text file that starts with '#' crashes it, and in an ascii
// body it turns "five" or a missing value into a number. Every encoding is read here instead,
// strictly; PCL supplies the cloud type and the LZF codec.

/// The cloud's description; its buffer is sized by the reader once the body is known to hold it.
pcl::PCLPointCloud2 emptyCloud(const PcdHeader& h) {
  pcl::PCLPointCloud2 cloud;
  cloud.fields = pclFields(h);
  cloud.width = static_cast<std::uint32_t>(h.width);
  cloud.height = static_cast<std::uint32_t>(h.height);
  cloud.point_step = static_cast<std::uint32_t>(h.point_step);
  cloud.row_step = cloud.point_step * cloud.width;
  cloud.is_dense = 0;
  return cloud;
}

std::string readBody(const std::string& path, const PcdHeader& h) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": cannot open: " + std::strerror(errno));
  in.seekg(static_cast<std::streamoff>(h.data_offset));
  std::string body((std::istreambuf_iterator<char>(in)), {});
  if (in.bad()) throw Error(path + ": read error");
  return body;
}

/// One ascii value into `out` as the field's binary type; false when it is not such a value.
bool parseValue(const std::string& tok, const PcdField& f, std::uint8_t* out) {
  const char* s = tok.c_str();
  char* end = nullptr;
  errno = 0;
  if (f.type == 'F') {
    const double v = std::strtod(s, &end);
    if (end == s || *end != '\0') return false;
    if (f.size == 4) {
      if (std::isfinite(v) && std::abs(v) > std::numeric_limits<float>::max()) return false;
      const auto x = static_cast<float>(v);
      std::memcpy(out, &x, 4);
    } else {
      std::memcpy(out, &v, 8);
    }
    return true;
  }
  const unsigned bits = static_cast<unsigned>(8 * f.size);
  if (f.type == 'I') {
    const long long v = std::strtoll(s, &end, 10);
    if (end == s || *end != '\0' || errno == ERANGE) return false;
    if (bits < 64 && (v < -(1LL << (bits - 1)) || v >= (1LL << (bits - 1)))) return false;
    std::memcpy(out, &v, f.size);  // little-endian: the low bytes
    return true;
  }
  if (tok[0] == '-') return false;
  const unsigned long long v = std::strtoull(s, &end, 10);
  if (end == s || *end != '\0' || errno == ERANGE) return false;
  if (bits < 64 && v >= (1ULL << bits)) return false;
  std::memcpy(out, &v, f.size);
  return true;
}

void readAscii(const std::string& path, const PcdHeader& h, pcl::PCLPointCloud2& cloud) {
  const std::string body = readBody(path, h);
  cloud.data.resize(h.points * h.point_step);  // bounded by the body's size (header check)
  std::size_t values = 0;
  for (const auto& f : h.fields) values += f.count;
  // Line numbers in messages count from the file's first line.
  std::size_t line_no = h.header_lines;
  std::size_t point = 0;
  std::size_t pos = 0;
  std::vector<std::string> tokens;
  while (pos < body.size()) {
    std::size_t end = body.find('\n', pos);
    if (end == std::string::npos) end = body.size();
    const std::string line = body.substr(pos, end - pos);
    pos = end + 1;
    ++line_no;
    tokens.clear();
    std::size_t i = 0;
    while (i < line.size()) {
      while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
      const std::size_t j = i;
      while (i < line.size() && !std::isspace(static_cast<unsigned char>(line[i]))) ++i;
      if (i > j) tokens.push_back(line.substr(j, i - j));
    }
    if (tokens.empty()) continue;
    const std::string where = path + ":" + std::to_string(line_no) + ": ";
    if (point == h.points)
      throw Error(where + "more points than the header's " + std::to_string(h.points));
    if (tokens.size() != values) {
      throw Error(where + "expected " + std::to_string(values) + " values, found " +
                  std::to_string(tokens.size()));
    }
    std::uint8_t* dst = cloud.data.data() + point * h.point_step;
    std::size_t t = 0;
    for (const auto& f : h.fields) {
      for (std::size_t c = 0; c < f.count; ++c, ++t) {
        if (!parseValue(tokens[t], f, dst + f.offset + c * f.size)) {
          throw Error(where + "'" + tokens[t] + "' is not a value of field " + f.name + " (" +
                      std::string(1, f.type) + std::to_string(f.size) + ")");
        }
      }
    }
    ++point;
  }
  if (point != h.points) {
    throw Error(path + ": the ascii body holds " + std::to_string(point) + " points, the header " +
                std::to_string(h.points) + " (file cut short?)");
  }
}

void readCompressed(const std::string& path, const PcdHeader& h, pcl::PCLPointCloud2& cloud) {
  const std::string body = readBody(path, h);
  if (h.points == 0) return;
  // (the cloud's buffer is allocated below, once the sizes are known to agree)
  std::uint32_t sizes[2];
  if (body.size() < sizeof(sizes)) throw Error(path + ": the compressed body is missing");
  std::memcpy(sizes, body.data(), sizeof(sizes));
  const std::uint64_t expected = static_cast<std::uint64_t>(h.points) * h.point_step;
  if (sizes[1] != expected) {
    throw Error(path + ": the compressed body unpacks to " + std::to_string(sizes[1]) +
                " bytes, the header needs " + std::to_string(expected));
  }
  if (sizes[0] > body.size() - sizeof(sizes)) {
    throw Error(path + ": the compressed body is shorter than it says (file cut short?)");
  }
  cloud.data.resize(h.points * h.point_step);
  std::vector<std::uint8_t> packed(sizes[1]);
  const unsigned got =
      pcl::lzfDecompress(body.data() + sizeof(sizes), sizes[0], packed.data(), sizes[1]);
  if (got != sizes[1]) throw Error(path + ": the compressed body is corrupt");
  // PCL stores a compressed body field by field: every point's value of the first field, ...
  std::size_t column = 0;
  for (const auto& f : h.fields) {
    const std::size_t bytes = f.size * f.count;
    for (std::size_t i = 0; i < h.points; ++i) {
      std::memcpy(cloud.data.data() + i * h.point_step + f.offset,
                  packed.data() + column + i * bytes, bytes);
    }
    column += bytes * h.points;
  }
}

}  // namespace

pcl::PCLPointCloud2 readPcd(const std::string& path) {
  const PcdHeader header = readPcdHeader(path);
  pcl::PCLPointCloud2 cloud = emptyCloud(header);
  switch (header.data) {
    case PcdHeader::Data::kBinary: {  // the header check made sure the file holds the body
      PcdChunkReader reader(path);
      cloud.data.resize(header.points * header.point_step);
      reader.read(cloud.data.data(), header.points);
      break;
    }
    case PcdHeader::Data::kAscii:
      readAscii(path, header, cloud);
      break;
    case PcdHeader::Data::kBinaryCompressed:
      readCompressed(path, header, cloud);
      break;
  }
  return cloud;
}

void writePcdBinary(const std::string& path, const pcl::PCLPointCloud2& cloud) {
  writePcdBinary(path, cloud.fields, cloud.point_step, cloud.width, cloud.height, cloud.data.data(),
                 cloud.data.size());
}

void writePcdBinary(const std::string& path, const std::vector<pcl::PCLPointField>& fields,
                    std::size_t point_step, std::uint32_t width, std::uint32_t height,
                    const std::uint8_t* data, std::size_t bytes) {
  const std::size_t points = static_cast<std::size_t>(width) * height;
  if (bytes != points * point_step) {
    throw Error(path + ": the cloud holds " + std::to_string(bytes) + " bytes for " +
                std::to_string(points) + " points of " + std::to_string(point_step));
  }
  PcdChunkWriter writer(path, fields, point_step, width, height);
  writer.write(data, points);
  writer.commit();
}

}  // namespace flexcloud
