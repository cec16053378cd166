#pragma once
// report.png: a picture of the run, drawn by the package's matplotlib script from the text files
// of the run (scripts/plot_report.py). Skipped, with the reason, where Python or matplotlib is
// missing.

#include <sys/types.h>

#include <string>

namespace flexcloud {

/// `python3 SCRIPT DIR` drawing DIR/report.png from the run's files in DIR, in a process of its
/// own, so that the map can be written meanwhile.
class PlotJob {
 public:
  /// Starts the script (a job that cannot start keeps the reason for finish()).
  PlotJob(const std::string& script, const std::string& dir);
  /// Stops and waits for a script that finish() did not wait for (an error on the way).
  ~PlotJob();
  PlotJob(const PlotJob&) = delete;
  PlotJob& operator=(const PlotJob&) = delete;
  /// Waits for the script: "" when the picture was written, else one line saying why not (no
  /// script given, python3 or matplotlib missing, the script failed).
  std::string finish();

 private:
  pid_t pid_ = -1;
  std::string dir_, log_, skipped_;
};

/// Where the package's plot script is: share/flexcloud/scripts/ under each CMAKE_PREFIX_PATH
/// entry (an install space), else the source tree the library was built from; "" if neither.
std::string findPlotScript();

}  // namespace flexcloud
