#pragma once
// Shared by the fuzz targets: the input as a file, for readers that take a path.

#include <sys/mman.h>
#include <unistd.h>

#include <cstdint>
#include <string>

namespace flexcloud::fuzz {

/// An anonymous in-memory file holding the bytes; path() names it for open().
class MemFile {
 public:
  MemFile(const std::uint8_t* data, std::size_t size) : fd_(::memfd_create("fuzz", 0)) {
    std::size_t done = 0;
    while (done < size) {
      const ssize_t n = ::write(fd_, data + done, size - done);
      if (n <= 0) break;
      done += static_cast<std::size_t>(n);
    }
  }
  ~MemFile() { ::close(fd_); }
  std::string path() const { return "/proc/self/fd/" + std::to_string(fd_); }

 private:
  int fd_;
};

}  // namespace flexcloud::fuzz
