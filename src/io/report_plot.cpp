#include "flexcloud/io/report_plot.h"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>

#include <cerrno>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <vector>

extern char** environ;

namespace flexcloud {
namespace {

namespace fs = std::filesystem;

/// The last non-empty line of a file ("" if none).
std::string lastLine(const std::string& path) {
  std::ifstream in(path);
  std::string line, last;
  while (std::getline(in, line)) {
    if (!line.empty()) last = line;
  }
  return last;
}

}  // namespace

PlotJob::PlotJob(const std::string& script, const std::string& dir) : dir_(dir) {
  if (script.empty()) {
    skipped_ = "report.png skipped: the plot script was not found";
    return;
  }
  if (!fs::exists(script)) {
    skipped_ = "report.png skipped: " + script + " does not exist";
    return;
  }
  log_ = (fs::path(dir) / ".plot.log").string();
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 2, log_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  // Debian's interpreter, where the packaged matplotlib is, before whatever PATH puts first.
  const std::string python = fs::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
  std::vector<std::string> args = {python, script, dir};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  const int spawned = posix_spawnp(&pid_, python.c_str(), &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) {
    pid_ = -1;
    skipped_ = "report.png skipped: python3 is not installed";
  }
}

PlotJob::~PlotJob() {
  if (pid_ <= 0) return;
  kill(pid_, SIGTERM);
  int status = 0;
  while (waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
  }
}

std::string PlotJob::finish() {
  if (pid_ <= 0) return skipped_;
  int status = 0;
  while (waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
  }
  pid_ = -1;
  const std::string why = lastLine(log_);
  std::error_code ec;
  fs::remove(log_, ec);
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0 && fs::exists(fs::path(dir_) / "report.png")) {
    return "";
  }
  if (WIFEXITED(status) && WEXITSTATUS(status) == 3) {
    return "report.png skipped: python3-matplotlib is not installed";
  }
  return "report.png skipped: the plot script failed" + (why.empty() ? "" : ": " + why);
}

std::string findPlotScript() {
  const char* prefixes = std::getenv("CMAKE_PREFIX_PATH");
  std::string rest = prefixes != nullptr ? prefixes : "";
  while (!rest.empty()) {
    const auto colon = rest.find(':');
    const fs::path candidate =
        fs::path(rest.substr(0, colon)) / "share/flexcloud/scripts/plot_report.py";
    if (fs::exists(candidate)) return candidate.string();
    rest = colon == std::string::npos ? "" : rest.substr(colon + 1);
  }
  const fs::path source = fs::path(FLEXCLOUD_SOURCE_DIR) / "scripts/plot_report.py";
  return fs::exists(source) ? source.string() : "";
}

}  // namespace flexcloud
