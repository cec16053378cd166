#pragma once
// From raw GNSS input (geodetic fixes or already-local points) to a clean, time-sorted list of
// ENU points, with every dropped fix counted by its reason.

#include <optional>
#include <string>
#include <vector>

#include "flexcloud/geo/geodesy.h"
#include "flexcloud/types.h"

namespace flexcloud {

/// A fix as it arrives, before any filtering. has_fix false: the receiver said NO_FIX.
/// A NaN std_enu component: the covariance is unknown.
struct RawFix {
  GeoFix fix;
  bool has_fix = true;
};

/// How many fixes were dropped, by reason.
struct GnssDropCounts {
  std::size_t no_fix = 0;              ///< receiver status NO_FIX
  std::size_t invalid = 0;             ///< NaN/inf or out-of-range coordinates or stamp
  std::size_t unknown_covariance = 0;  ///< covariance unknown and no default_std_dev set
  std::size_t duplicate = 0;           ///< same stamp as an earlier fix
  std::size_t outlier = 0;             ///< position jump no vehicle could make
  std::size_t total() const { return no_fix + invalid + unknown_covariance + duplicate + outlier; }
};

/// The GNSS ready for interpolation: sorted by stamp (time offset applied), one per stamp.
struct PreparedGnss {
  std::optional<Datum> datum;  ///< empty when the input was local and no datum was given
  std::vector<GnssPoint> points;
  std::size_t received = 0;
  GnssDropCounts dropped;
};

/// The numbers the GNSS preparation uses; gnssOptions() (params.h) fills them from the
/// parameter table.
struct GnssOptions {
  std::optional<Datum> datum;         ///< empty: the earliest valid fix is the datum
  double default_std_dev = 0.0;       ///< m, for fixes without one; <= 0: none
  bool estimate_unknown_std = false;  ///< keep fixes without a std-dev (the fusion estimates it)
  bool drop_jumps = false;            ///< drop position jumps no vehicle could make
  double time_offset = 0.0;           ///< s, added to every fix's stamp
  double max_speed = 0.0;             ///< m/s, the fastest plausible motion between fixes
};

/// Geodetic fixes to ENU. The datum is the options' or else the earliest valid fix.
/// Throws Error when no fix is usable.
PreparedGnss prepareGeodeticGnss(const std::vector<RawFix>& fixes, const GnssOptions& options);

/// Already-local GNSS points (ENU metres of the options' datum, if given). Same filtering.
PreparedGnss prepareLocalGnss(const std::vector<GnssPoint>& points, const GnssOptions& options);

/// The fixes dropped, in words by reason ("3 invalid (...), 2 in jumps ..."); empty when none was.
std::string droppedInWords(const GnssDropCounts& dropped);

}  // namespace flexcloud
