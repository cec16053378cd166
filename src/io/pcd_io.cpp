#include "flexcloud/io/pcd_io.h"

#include <pcl/console/print.h>
#include <pcl/io/pcd_io.h>

#include <cerrno>
#include <cstring>
#include <fstream>

#include "flexcloud/io/atomic_file.h"
#include "flexcloud/types.h"

namespace flexcloud {
namespace {

/// PCL prints its own errors to the console; we report ours instead, once.
void quietPcl() { pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS); }

}  // namespace

pcl::PCLPointCloud2 readPcd(const std::string& path) {
  quietPcl();
  {
    std::ifstream probe(path, std::ios::binary);
    if (!probe) throw Error(path + ": cannot open: " + std::strerror(errno));
    char magic[16] = {};
    probe.read(magic, sizeof(magic));
    const std::string head(magic, static_cast<std::size_t>(probe.gcount()));
    if (head.rfind("# .PCD", 0) != 0 && head.rfind("VERSION", 0) != 0 &&
        head.rfind("FIELDS", 0) != 0 && head.rfind("#", 0) != 0) {
      throw Error(path + ": not a PCD file (no PCD header)");
    }
  }
  pcl::PCDReader reader;
  pcl::PCLPointCloud2 cloud;
  Eigen::Vector4f origin;
  Eigen::Quaternionf orientation;
  int version = 0;
  int data_type = 0;
  unsigned int data_idx = 0;
  int rc = 0;
  try {
    rc = reader.readHeader(path, cloud, origin, orientation, version, data_type, data_idx);
    if (rc == 0) rc = reader.read(path, cloud, origin, orientation, version);
  } catch (const std::exception& e) {
    throw Error(path + ": unreadable PCD: " + e.what());
  }
  if (rc != 0) {
    throw Error(path + ": unreadable PCD (bad header, unknown field type, or a body shorter than "
                       "the header promises)");
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
