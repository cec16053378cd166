#pragma once

#include <string>

namespace flexcloud {

/// Peak resident memory of a process so far, MiB (0 where /proc is not available): VmHWM of
/// /proc/PID/status, this process by default.
double peakMemoryMb(const std::string& status = "/proc/self/status");

/// Has this process's allocator keep freed memory for its next allocations instead of handing
/// it back to the kernel at once: blocks up to 32 MiB come from the heap rather than from a
/// fresh mapping each, and the heap is trimmed only above 128 MiB free. The fusion allocates and
/// frees the same tens of megabytes at every solve; handed back each time, every page faulted
/// in again (on a2rl a third of a fresh tool's fusion time was the kernel's). Peak memory is
/// unchanged. For programs that own their process (the tools and the node), not a nodelet,
/// which shares its manager's allocator.
void keepFreedMemory();

}  // namespace flexcloud
