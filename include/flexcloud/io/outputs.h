#pragma once
// The files of a georeferencing run, written so that a folder never holds a half-done set:
// everything is written into a staging folder and moved into place at the end, report.json last.

#include <pcl/PCLPointCloud2.h>

#include <functional>
#include <optional>
#include <string>

#include "flexcloud/georeference.h"
#include "flexcloud/io/autoware_map.h"
#include "flexcloud/io/las_writer.h"
#include "flexcloud/warp/cloud_warp.h"

namespace flexcloud {

class PlotJob;

/// What happened to the map, for the report.
struct MapInfo {
  std::string input;  ///< file or topic it came from
  WarpStats warp;
  /// The field whose pose moved each point (pose_rebuild.h); empty: the rubber sheet moved them.
  std::string pose_field;
  /// Why a field that names poses was not used ("" where none was found or it was used).
  std::string pose_field_note;
  bool has_truth = false;
  ErrorStats truth_aligned;      ///< rigid-only map against the ground truth
  ErrorStats truth_rubbersheet;  ///< final map against the ground truth
  double read_seconds = 0.0;
  double grid_seconds = 0.0;  ///< building the point location grid
  double warp_seconds = 0.0;
  double write_seconds = 0.0;
};

/// Frame names written into origin.yaml and the report.
struct FrameNames {
  std::string enu = "enu";
  std::string map = "map";
};

/// What the caller knows about the run beyond the result.
struct RunContext {
  FrameNames frames;
  const MapInfo* map = nullptr;  ///< null: no map was warped
  /// Peak resident memory (MB) of the process that made the result; negative: not measured
  /// (inside a nodelet manager the process is the manager, so the node does not report it).
  double peak_memory_mb = -1.0;
  /// When set, called once everything but report.json is written; its figure replaces
  /// peak_memory_mb (so the report covers the exports too).
  std::function<double()> measure_peak;
  /// Stops writeOutputs before anything is moved into place.
  const CancelToken* cancel = &neverCancelled();
  /// scripts/plot_report.py of the package (empty: not found; report.png is then skipped).
  std::string plot_script;
  /// The plot started before the run (the tool, so that Python loads beside the fusion); null:
  /// one is started from plot_script once the files are written.
  PlotJob* plot = nullptr;
};

/// What was written beside the map and the trajectories.
struct ExportSummary {
  bool geojson = false;  ///< trajectories.geojson (needs a datum)
  std::optional<AutowareSummary> autoware;
  std::optional<LasSummary> las;
  bool plot = false;               ///< report.png
  double seconds = 0.0;            ///< writing autoware/ and the LAS
  std::vector<std::string> notes;  ///< one line per output that was skipped, and why
};

std::string reportJson(const GeoreferenceResult& r, const Params& params, const RunContext& run,
                       const ExportSummary* exports = nullptr);
std::string originYaml(const GeoreferenceResult& r, const FrameNames& frames);
std::string controlPointsText(const GeoreferenceResult& r);
/// The interpolated GNSS at every matched pose as TUM (identity orientation).
std::string gnssTum(const GeoreferenceResult& r);

/// `poses` as TUM text under a comment line that says their clock: the SLAM's (the poses' own
/// stamps), or with `gnss_clock` the GNSS's (the stamps less r.clock_offset), as a GNSS-clock
/// reference in evo needs them.
/// trajectory_sigma.txt: per pose of the result its stamp and horizontal and vertical sigma.
std::string sigmaText(const GeoreferenceResult& r);

std::string tumText(Trajectory poses, const GeoreferenceResult& r, bool gnss_clock);
/// Every fix the fusion judged, with its residual, weight and verdict (gnss_fixes.txt).
std::string fixesText(const GeoreferenceResult& r);

/// resultWarnings() with what the map adds (map null: none): for a map rebuilt from its points'
/// poses, the share of points that named no pose instead of the share beyond the GNSS coverage,
/// and why a field that names poses was not used.
std::vector<std::string> mapWarnings(const GeoreferenceResult& r, const Params& params,
                                     const MapInfo* map, const std::string& map_frame);

/// Writes the georeferenced map to the path it is given (a finished cloud, or a streaming warp
/// that fills the MapInfo as it goes).
using MapWriter = std::function<void(const std::string& path)>;

/// Checks, before anything is written, that the outputs params asks for can be made from this
/// result: a datum for autoware/ and the LAS, inside UTM's reach where a projector needs it.
/// Throws Error naming the parameter.
void checkExports(const GeoreferenceResult& r, const Params& params);

/// Writes map_georeferenced.pcd (through write_map, if given; it runs first, so the report
/// sees what it put into run.map), trajectory_{gnss,slam,aligned,rubbersheet}.txt,
/// control_points.txt, with the fusion trajectory_fused.txt and gnss_fixes.txt, origin.yaml,
/// trajectories.geojson (with a datum), with a map and params.autoware the folder autoware/,
/// with a map and params.las map_georeferenced.las, report.png (where matplotlib is) and
/// report.json into `dir` (created if needed). Throws Error, also when run.cancel is cancelled;
/// on failure `dir` keeps its previous files (and is removed if the run created it).
ExportSummary writeOutputs(const std::string& dir, const GeoreferenceResult& r,
                           const Params& params, const MapWriter& write_map, const RunContext& run);

}  // namespace flexcloud
