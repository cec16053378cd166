// Fuzz target: PCD input (header check, ascii / binary / compressed bodies, the chunked reader
// and the streamed warp) on any bytes.
#include <cstdint>
#include <string>

#include "flexcloud/io/cloud_layout.h"
#include "flexcloud/io/map_stream.h"
#include "flexcloud/io/pcd_io.h"
#include "flexcloud/io/pcd_stream.h"
#include "flexcloud/warp/cloud_warp.h"
#include "fuzz_util.h"

namespace {

const flexcloud::RubberSheet& sheet() {
  static const flexcloud::RubberSheet* s = [] {
    std::vector<Eigen::Vector3d> src, dst;
    for (int c = 0; c < 8; ++c) {
      src.emplace_back(c & 1 ? 50 : -50, c & 2 ? 50 : -50, c & 4 ? 50 : -50);
      dst.push_back(src.back() + Eigen::Vector3d(1, 2, 3));
    }
    src.emplace_back(0, 0, 0);
    dst.emplace_back(1, 2, 4);
    flexcloud::Affine34 outside = flexcloud::Affine34::Zero();
    outside.leftCols<3>().setIdentity();
    return new flexcloud::RubberSheet(src, dst, outside);
  }();
  return *s;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace flexcloud;
  const fuzz::MemFile file(data, size);
  try {
    pcl::PCLPointCloud2 cloud = readPcd(file.path());
    warpCloud(cloud, sheet(), 1, "fuzz");
  } catch (const Error&) {
  }
  try {
    MapInfo info;
    MapStreamOptions o;
    o.threads = 1;
    o.chunk_points = 7;
    o.in_place = false;  // /tmp may not reserve space; the pipeline path reads through buffers
    warpPcdFile(file.path(), "/tmp/flexcloud_fuzz_out.pcd", sheet(), o, info);
  } catch (const Error&) {
  }
  return 0;
}
