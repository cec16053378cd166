#pragma once
// Text trajectories: TUM poses and GNSS tables, read with line-precise errors.

#include <string>
#include <vector>

#include "flexcloud/input/gnss.h"
#include "flexcloud/types.h"

namespace flexcloud {

enum class StampUnit {
  kAuto,  ///< by the stamps' size: above 1e16 ns, 1e13 us, 1e10 ms, else s (Unix epochs)
  kSeconds,
  kMilliseconds,
  kMicroseconds,
  kNanoseconds,
};

/// Parses "auto" / "s" / "ms" / "us" / "ns"; throws Error otherwise.
StampUnit parseStampUnit(const std::string& text);

/// TUM file: "stamp x y z qx qy qz qw" per line; '#' comments, blank lines and a first line
/// that is not numbers (a header) skipped; commas, semicolons and tabs count as spaces. Non-finite
/// numbers are kept (the pipeline counts and drops them). Throws Error "FILE:LINE: ..." for a
/// missing file, a wrong column count or a non-number.
Trajectory readTumFile(const std::string& path, StampUnit unit = StampUnit::kAuto);

/// GNSS file "stamp lat lon alt [std_e std_n std_u]" (deg, deg, m, m); without the std-dev
/// columns the covariance is unknown.
std::vector<RawFix> readGeodeticGnssFile(const std::string& path,
                                         StampUnit unit = StampUnit::kAuto);

/// GNSS file "stamp x y z [sx sy sz]" in a local ENU frame (m).
std::vector<GnssPoint> readLocalGnssFile(const std::string& path,
                                         StampUnit unit = StampUnit::kAuto);

/// Points "x y z" per line (m); '#' comments and blank lines skipped. Throws Error
/// "FILE:LINE: ..." for a wrong column count or a non-number, "FILE: point N ..." for a
/// non-finite point.
std::vector<Eigen::Vector3d> readPointsFile(const std::string& path);

/// The same readers on text already in memory; `name` is used in error messages.
Trajectory parseTum(const std::string& text, const std::string& name, StampUnit unit);
std::vector<RawFix> parseGeodeticGnss(const std::string& text, const std::string& name,
                                      StampUnit unit);
std::vector<GnssPoint> parseLocalGnss(const std::string& text, const std::string& name,
                                      StampUnit unit);

/// TUM text of a trajectory (stamps in seconds, 9 decimals; positions to the micrometre).
std::string formatTum(const Trajectory& poses);

/// Appends v with `decimals` (0-32) decimals in fixed notation: the text printf's "%.*f" writes
/// (std::to_chars, a few times faster than a stream).
void appendFixed(std::string& s, double v, int decimals);

/// Reads a whole file; throws Error naming it when missing or unreadable.
std::string readWholeFile(const std::string& path);

}  // namespace flexcloud
