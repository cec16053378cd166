#include "body_copy.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <vector>

#include "flexcloud/io/pcd_header.h"
#include "flexcloud/io/pcd_stream.h"
#include "flexcloud/types.h"

namespace flexcloud {
namespace {

/// Copies `bytes` from in_fd at in_off to out_fd at out_off in the kernel (copy_file_range),
/// or through a buffer where the filesystems cannot.
void copyRange(int in_fd, off_t in_off, int out_fd, off_t out_off, std::size_t bytes,
               const std::string& name) {
  bool kernel = true;
  std::vector<std::uint8_t> buf;
  while (bytes > 0) {
    ssize_t n = -1;
    if (kernel) {
      n = ::copy_file_range(in_fd, &in_off, out_fd, &out_off, bytes, 0);
      if (n < 0 && (errno == EXDEV || errno == EINVAL || errno == ENOSYS || errno == EOPNOTSUPP)) {
        kernel = false;
        continue;
      }
    } else {
      if (buf.empty()) buf.resize(std::size_t{1} << 22);
      n = ::pread(in_fd, buf.data(), std::min(bytes, buf.size()), in_off);
      if (n > 0) {
        writeAt(out_fd, buf.data(), static_cast<std::size_t>(n), out_off, name);
        in_off += n;
        out_off += n;
      }
    }
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      throw Error(
          name + ": copying the map failed" +
          (n < 0 ? std::string(": ") + std::strerror(errno) : std::string(" (input cut short?)")));
    }
    bytes -= static_cast<std::size_t>(n);
  }
}

}  // namespace

FdGuard::~FdGuard() {
  if (fd >= 0) ::close(fd);
}

int FdGuard::release() {
  const int f = fd;
  fd = -1;
  return f;
}

BodyCopier::BodyCopier(BodyRange range)
    : range_(std::move(range)), thread_([this] { copyAll(); }) {}

BodyCopier::~BodyCopier() { stop(); }

void BodyCopier::waitFor(std::size_t points) {
  std::unique_lock<std::mutex> lock(m_);
  cv_.wait(lock, [&] { return copied_ >= points || error_; });
  if (error_) std::rethrow_exception(error_);
}

double BodyCopier::finish() {
  stop();
  if (error_) std::rethrow_exception(error_);
  return seconds_;
}

void BodyCopier::copyAll() {
  const BodyRange& r = range_;
  const std::size_t chunk = std::max<std::size_t>(1, r.chunk);
  try {
    for (std::size_t first = 0; first < r.points && !stop_; first += chunk) {
      const std::size_t n = std::min(chunk, r.points - first);
      const auto t0 = std::chrono::steady_clock::now();
      copyRange(r.in_fd, static_cast<off_t>(r.in_offset + first * r.step), r.out_fd,
                static_cast<off_t>(r.out_offset + first * r.step), n * r.step, r.name);
      seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      std::lock_guard<std::mutex> lock(m_);
      copied_ = first + n;
      cv_.notify_all();
    }
  } catch (...) {
    std::lock_guard<std::mutex> lock(m_);
    error_ = std::current_exception();
    cv_.notify_all();
  }
}

void BodyCopier::stop() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

bool reserveSpace(int fd, std::size_t bytes, const std::string& name) {
  const int rc = ::posix_fallocate(fd, 0, static_cast<off_t>(bytes));
  if (rc == EOPNOTSUPP || rc == EINVAL || rc == ENOSYS) return false;
  if (rc != 0) {
    throw Error(name + ": cannot reserve " + std::to_string(bytes) +
                " bytes: " + std::strerror(rc));
  }
  return true;
}

std::string outputHeader(const PcdHeader& map) {
  return binaryPcdHeader(pclFields(map), map.point_step, static_cast<std::uint32_t>(map.width),
                         static_cast<std::uint32_t>(map.height));
}

bool startCopy(OutputBody& body, const std::string& in, const PcdHeader& map,
               const std::string& header, std::size_t chunk, const std::string& name) {
  if (!reserveSpace(body.out.fd, header.size() + map.points * map.point_step, name)) return false;
  writeHeader(body.out.fd, header, name);
  body.in.fd = ::open(in.c_str(), O_RDONLY | O_CLOEXEC);
  if (body.in.fd < 0) throw Error(in + ": cannot open: " + std::strerror(errno));
  body.copier = std::make_unique<BodyCopier>(BodyRange{body.in.fd, body.out.fd, map.data_offset,
                                                       header.size(), map.points, map.point_step,
                                                       chunk, name});
  return true;
}

void writeHeader(int fd, const std::string& text, const std::string& name) {
  writeAt(fd, reinterpret_cast<const std::uint8_t*>(text.data()), text.size(), 0, name);
}

void readAt(int fd, std::uint8_t* buf, std::size_t bytes, off_t offset, const std::string& name) {
  for (std::size_t done = 0; done < bytes;) {
    const ssize_t n = ::pread(fd, buf + done, bytes - done, offset + static_cast<off_t>(done));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      throw Error(name + ": read failed" +
                  (n < 0 ? std::string(": ") + std::strerror(errno) : std::string(" (cut short)")));
    }
    done += static_cast<std::size_t>(n);
  }
}

void writeAt(int fd, const std::uint8_t* buf, std::size_t bytes, off_t offset,
             const std::string& name) {
  for (std::size_t done = 0; done < bytes;) {
    const ssize_t n = ::pwrite(fd, buf + done, bytes - done, offset + static_cast<off_t>(done));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) throw Error(name + ": write failed: " + std::strerror(n < 0 ? errno : ENOSPC));
    done += static_cast<std::size_t>(n);
  }
}

}  // namespace flexcloud
