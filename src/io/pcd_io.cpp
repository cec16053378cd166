#include "flexcloud/io/pcd_io.h"

#include <pcl/console/print.h>
#include <pcl/io/pcd_io.h>


#include "flexcloud/io/atomic_file.h"
#include "flexcloud/io/pcd_header.h"
#include "flexcloud/types.h"

namespace flexcloud {
namespace {

/// PCL prints its own errors to the console; we report ours instead, once.
void quietPcl() { pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS); }

}  // namespace

pcl::PCLPointCloud2 readPcd(const std::string& path) {
  quietPcl();
  readPcdHeader(path);  // PCL trusts the header; check it first
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
  quietPcl();
  AtomicFile file(path);
  pcl::PCDWriter writer;
  int rc = 0;
  try {
    rc = writer.writeBinary(file.tempPath(), cloud, Eigen::Vector4f::Zero(),
                            Eigen::Quaternionf::Identity());
  } catch (const std::exception& e) {
    throw Error(path + ": cannot write PCD: " + e.what());
  }
  if (rc != 0) throw Error(path + ": cannot write PCD (disk full or folder not writable?)");
  file.commit();
}

}  // namespace flexcloud
