#pragma once

namespace flexcloud {

/// Peak resident memory of this process so far, MiB (0 where /proc is not available).
double peakMemoryMb();

}  // namespace flexcloud
