// Fuzz target: the whole pipeline on a drive read from fuzzed text (GNSS and poses split at the
// first '|'), with NaN, huge, duplicate, disordered and degenerate values as they come.
#include <cstdint>
#include <string>

#include "flexcloud/georeference.h"
#include "flexcloud/io/text_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace flexcloud;
  const std::string text(reinterpret_cast<const char*>(data), size);
  const auto bar = text.find('|');
  if (bar == std::string::npos) return 0;
  try {
    DriveInput in;
    in.local_gnss = parseLocalGnss(text.substr(0, bar), "gnss", StampUnit::kSeconds);
    in.poses = parseTum(text.substr(bar + 1), "poses", StampUnit::kSeconds);
    Params p;
    p.control_points = 8;
    p.stddev_threshold = 1.0;
    p.max_gap = 5.0;
    const GeoreferenceResult r = georeference(in, p);
    r.sheet->transform(Eigen::Vector3d(1.0, 2.0, 3.0));  // the grid, too
  } catch (const Error&) {
  }
  return 0;
}
