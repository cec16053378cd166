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

#include "flexcloud/io/pcd_ascii.h"
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

void readAscii(const std::string& path, const PcdHeader& h, pcl::PCLPointCloud2& cloud) {
  PcdAsciiReader reader(path);
  cloud.data.resize(h.points * h.point_step);  // bounded by the body's size (header check)
  reader.read(cloud.data.data(), h.points);
  std::vector<std::uint8_t> extra(std::max<std::size_t>(1, h.point_step));
  reader.read(extra.data(), 1);  // throws for a point beyond the header's count
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
