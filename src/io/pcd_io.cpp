#include "flexcloud/io/pcd_io.h"

#include <pcl/console/print.h>
#include <pcl/io/pcd_io.h>


#include "flexcloud/io/pcd_header.h"
#include "flexcloud/io/pcd_stream.h"
#include "flexcloud/types.h"

namespace flexcloud {
namespace {

/// PCL prints its own errors to the console; we report ours instead, once.
void quietPcl() { pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS); }

}  // namespace

pcl::PCLPointCloud2 readPcd(const std::string& path) {
  quietPcl();
  const PcdHeader header = readPcdHeader(path);  // PCL trusts the header; check it first
  if (header.data == PcdHeader::Data::kBinary) {
    // Our own reader: straight into the cloud's buffer, no memory map beside it.
    PcdChunkReader reader(path);
    pcl::PCLPointCloud2 cloud;
    cloud.fields = pclFields(header);
    cloud.width = static_cast<std::uint32_t>(header.width);
    cloud.height = static_cast<std::uint32_t>(header.height);
    cloud.point_step = static_cast<std::uint32_t>(header.point_step);
    cloud.row_step = cloud.point_step * cloud.width;
    cloud.is_dense = 0;
    cloud.data.resize(header.points * header.point_step);
    reader.read(cloud.data.data(), header.points);
    return cloud;
  }
  pcl::PCDReader reader;
  pcl::PCLPointCloud2 cloud;
  Eigen::Vector4f origin;
  Eigen::Quaternionf orientation;
  int version = 0;
  int rc = 0;
  try {
    rc = reader.read(path, cloud, origin, orientation, version);
  } catch (const std::exception& e) {
    throw Error(path + ": unreadable PCD: " + e.what());
  }
  if (rc != 0) {
    throw Error(path + ": unreadable PCD body (corrupt compressed data or malformed ascii rows)");
  }
  return cloud;
}

void writePcdBinary(const std::string& path, const pcl::PCLPointCloud2& cloud) {
  writePcdBinary(path, cloud.fields, cloud.point_step, cloud.width, cloud.height,
                 cloud.data.data(), cloud.data.size());
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
