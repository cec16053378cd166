#pragma once
// report.png: a picture of the run, drawn by the package's matplotlib script from the text files
// of the run (scripts/plot_report.py). Skipped, with the reason, where Python or matplotlib is
// missing.

#include <string>

namespace flexcloud {

/// Runs `python3 SCRIPT DIR` to draw DIR/report.png from the run's files in DIR. Returns "" when
/// the picture was written, else one line saying why not (no script given, python3 or matplotlib
/// missing, the script failed).
std::string plotReport(const std::string& script, const std::string& dir);

/// Where the package's plot script is: share/flexcloud/scripts/ under each CMAKE_PREFIX_PATH
/// entry (an install space), else the source tree the library was built from; "" if neither.
std::string findPlotScript();

}  // namespace flexcloud
