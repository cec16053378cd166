#pragma once
// report.png: a picture of the run, drawn by the package's matplotlib script from the text files
// of the run (scripts/plot_report.py). Skipped, with the reason, where Python or matplotlib is
// missing.

#include <sys/types.h>

#include <string>

namespace flexcloud {

/// `python3 SCRIPT -` drawing DIR/report.png from the run's files in DIR, in a process of its
/// own. It starts before the run (Python and matplotlib load beside the georeferencing), is told
/// the folder once the files are there, and draws while the map is written.
class PlotJob {
 public:
  /// Starts the script (a job that cannot start keeps the reason for finish()).
  explicit PlotJob(const std::string& script);
  /// Stops and waits for a script that finish() did not wait for (an error on the way).
  ~PlotJob();
  PlotJob(const PlotJob&) = delete;
  PlotJob& operator=(const PlotJob&) = delete;
  /// Has the script draw DIR/report.png from the files in DIR; once per job.
  void draw(const std::string& dir);
  /// Waits for the script: "" when the picture was written, else one line saying why not (no
  /// script given, python3 or matplotlib missing, the script failed, draw() never called).
  std::string finish();
  /// Stops the script and waits for it: on an error, before the folder it draws into goes.
  void stop();

 private:
  pid_t pid_ = -1;
  int to_script_ = -1;    ///< the script's standard input: the folder, one line
  int from_script_ = -1;  ///< the script's standard error, its last line the reason it failed
  std::string dir_, skipped_;
};

/// Where the package's plot script is: share/flexcloud/scripts/ under each CMAKE_PREFIX_PATH
/// entry (an install space), else the source tree the library was built from; "" if neither.
std::string findPlotScript();

}  // namespace flexcloud
