#include "flexcloud/io/memory.h"

#include <malloc.h>

#include <fstream>
#include <string>

namespace flexcloud {

double peakMemoryMb(const std::string& status_path) {
  // VmHWM belongs to this program's address space: unlike getrusage's ru_maxrss it does not
  // carry over the pages of a large parent that started us.
  std::ifstream status(status_path);
  std::string key;
  while (status >> key) {
    if (key == "VmHWM:") {
      double kb = 0.0;
      status >> kb;
      return kb / 1024.0;
    }
    std::getline(status, key);
  }
  return 0.0;
}

void keepFreedMemory() {
  constexpr int kMmapThreshold = 32 << 20;
  constexpr int kTrimThreshold = 128 << 20;
  ::mallopt(M_MMAP_THRESHOLD, kMmapThreshold);
  ::mallopt(M_TRIM_THRESHOLD, kTrimThreshold);
}

}  // namespace flexcloud
