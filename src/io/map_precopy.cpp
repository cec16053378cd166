#include "flexcloud/io/map_precopy.h"

#include <fcntl.h>
#include <unistd.h>

#include <exception>
#include <filesystem>

#include "body_copy.h"
#include "flexcloud/io/map_stream.h"
#include "flexcloud/io/pcd_header.h"
#include "flexcloud/types.h"

namespace flexcloud {
namespace {

/// The folder itself if it exists, else its nearest existing parent: the unnamed file must lie
/// on the output's filesystem to be named there later.
std::string nearestFolder(const std::string& dir) {
  std::filesystem::path p = std::filesystem::absolute(dir);
  while (!std::filesystem::exists(p) && p.has_parent_path() && p != p.parent_path()) {
    p = p.parent_path();
  }
  return p.string();
}

}  // namespace

struct MapPrecopy::Impl {
  std::string in;
  OutputBody body;
};

MapPrecopy::MapPrecopy() : impl_(std::make_unique<Impl>()) {}

MapPrecopy::~MapPrecopy() = default;

std::unique_ptr<MapPrecopy> MapPrecopy::start(const std::string& in, const std::string& out_dir) {
  try {
    const PcdHeader h = readPcdHeader(in);
    if (h.data != PcdHeader::Data::kBinary || h.points == 0) return nullptr;
    std::unique_ptr<MapPrecopy> p(new MapPrecopy);
    OutputBody& b = p->impl_->body;
    b.out.fd = ::open(nearestFolder(out_dir).c_str(), O_TMPFILE | O_RDWR | O_CLOEXEC, 0644);
    if (b.out.fd < 0) return nullptr;
    if (!startCopy(b, in, h, outputHeader(h), MapStreamOptions().chunk_points, out_dir))
      return nullptr;
    p->impl_->in = in;
    return p;
  } catch (const std::exception&) {
    return nullptr;  // the warp meets the same problem and reports it
  }
}

bool MapPrecopy::takeAs(const std::string& in, const std::string& path, OutputBody& body) {
  OutputBody& b = impl_->body;
  if (in != impl_->in || !b.copier) return false;
  const std::string self = "/proc/self/fd/" + std::to_string(b.out.fd);
  if (::linkat(AT_FDCWD, self.c_str(), AT_FDCWD, path.c_str(), AT_SYMLINK_FOLLOW) != 0) {
    return false;
  }
  body.copier = std::move(b.copier);  // first: the copier stops before the files close
  body.in.fd = b.in.release();
  body.out.fd = b.out.release();
  return true;
}

}  // namespace flexcloud
