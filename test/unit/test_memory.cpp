// The process memory helpers: the peak read from a status file, and the allocator keeping what
// was freed.
#include <gtest/gtest.h>
#include <malloc.h>

#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>

#include "flexcloud/io/memory.h"

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define FLEXCLOUD_OWN_ALLOCATOR 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || \
    __has_feature(memory_sanitizer)
#define FLEXCLOUD_OWN_ALLOCATOR 1
#endif
#endif

namespace flexcloud {
namespace {

TEST(Memory, PeakIsVmHwmOfTheStatusFile) {
  const std::string path = testing::TempDir() + "/flexcloud_status";
  std::ofstream(path) << "Name:\tx\nVmPeak:\t  9999 kB\nVmHWM:\t    3072 kB\nVmRSS:\t 100 kB\n";
  EXPECT_DOUBLE_EQ(peakMemoryMb(path), 3.0);
  EXPECT_DOUBLE_EQ(peakMemoryMb(path + ".absent"), 0.0);
  EXPECT_GT(peakMemoryMb(), 1.0);  // this process
}

TEST(Memory, AFreedBlockStaysWithTheProcess) {
#ifdef FLEXCLOUD_OWN_ALLOCATOR
  GTEST_SKIP() << "a sanitizer's allocator stands in for glibc's here; skipped";
#endif
  keepFreedMemory();
  constexpr std::size_t kBlock = 24u << 20;  // under the 32 MiB kept on the heap
  // mallinfo2 from glibc 2.33 on; mallinfo's int fields hold these sizes as well.
#if __GLIBC__ > 2 || (__GLIBC__ == 2 && __GLIBC_MINOR__ >= 33)
  const auto info = [] { return mallinfo2(); };
#else
  const auto info = [] { return mallinfo(); };
#endif
  const auto before = info();
  char* block = static_cast<char*>(std::malloc(kBlock));
  ASSERT_NE(block, nullptr);
  std::memset(block, 1, kBlock);
  const auto held = info();
  EXPECT_EQ(held.hblks, before.hblks);  // from the heap, not a mapping of its own
  std::free(block);
  const auto after = info();
  EXPECT_GE(static_cast<std::size_t>(after.arena), kBlock);     // the heap was not trimmed back
  EXPECT_GE(static_cast<std::size_t>(after.fordblks), kBlock);  // and the block is free again
}

}  // namespace
}  // namespace flexcloud
