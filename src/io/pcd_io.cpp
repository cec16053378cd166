#include "flexcloud/io/pcd_io.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>

#include "flexcloud/io/pcd_ascii.h"
#include "flexcloud/io/pcd_compressed.h"
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

void readAscii(const std::string& path, const PcdHeader& h, pcl::PCLPointCloud2& cloud) {
  PcdAsciiReader reader(path);
  cloud.data.resize(h.points * h.point_step);  // bounded by the body's size (header check)
  reader.read(cloud.data.data(), h.points);
  std::vector<std::uint8_t> extra(std::max<std::size_t>(1, h.point_step));
  reader.read(extra.data(), 1);  // throws for a point beyond the header's count
}

/// Through the same decoder as the streamed warp (its column-by-column LZF): the whole body
/// is never held packed beside the cloud.
void readCompressed(const std::string& path, const PcdHeader& h, pcl::PCLPointCloud2& cloud) {
  PcdCompressedReader reader(path);
  cloud.data.resize(h.points * h.point_step);
  if (reader.read(cloud.data.data(), h.points) != h.points) {
    throw Error(path + ": the compressed body holds fewer points than the header");
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
