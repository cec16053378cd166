#pragma once
// A binary map's body copied towards its output from the start of a run, while the drive is
// georeferenced, into an unnamed file beside the output folder: the warp takes the copy over
// (names it as its output's temporary file) instead of copying once the sheet exists. Not taken
// over (an error before the warp), the unnamed file goes with the run's handle on it.

#include <memory>
#include <string>

namespace flexcloud {

struct OutputBody;

class MapPrecopy {
 public:
  /// Starts copying map `in` for an output under folder `out_dir` (which need not exist yet);
  /// null where that cannot start (not a binary map, a filesystem without unnamed files or
  /// without space reservation, any error): the warp then copies, and reports, as before.
  static std::unique_ptr<MapPrecopy> start(const std::string& in, const std::string& out_dir);
  ~MapPrecopy();
  MapPrecopy(const MapPrecopy&) = delete;
  MapPrecopy& operator=(const MapPrecopy&) = delete;

  /// Names the copy of map `in` `path` and hands it over; false, nothing named, for another
  /// map, a copy already taken, or where naming fails (another filesystem).
  bool takeAs(const std::string& in, const std::string& path, OutputBody& body);

 private:
  MapPrecopy();
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace flexcloud
