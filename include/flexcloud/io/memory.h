#pragma once

#include <string>

namespace flexcloud {

/// Peak resident memory of a process so far, MiB (0 where /proc is not available): VmHWM of
/// /proc/PID/status, this process by default.
double peakMemoryMb(const std::string& status = "/proc/self/status");

}  // namespace flexcloud
