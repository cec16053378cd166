#include "flexcloud/io/report_plot.h"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <vector>

extern char** environ;

namespace flexcloud {
namespace {

namespace fs = std::filesystem;

/// The last non-empty line of `text` ("" if none).
std::string lastLine(const std::string& text) {
  std::istringstream in(text);
  std::string line, last;
  while (std::getline(in, line)) {
    if (!line.empty()) last = line;
  }
  return last;
}

/// Writes `text` into a pipe whose reader may be gone (a script that failed at its start),
/// without the SIGPIPE that would end this process.
void writeToPipe(int fd, const std::string& text) {
  sigset_t pipe_signal, old;
  sigemptyset(&pipe_signal);
  sigaddset(&pipe_signal, SIGPIPE);
  pthread_sigmask(SIG_BLOCK, &pipe_signal, &old);
  const ssize_t written = write(fd, text.data(), text.size());
  if (written < 0 && errno == EPIPE) {
    const timespec now{};
    sigtimedwait(&pipe_signal, nullptr, &now);  // the signal it raised, taken back
  }
  pthread_sigmask(SIG_SETMASK, &old, nullptr);
}

/// Everything a pipe gives until its writer closes it.
std::string readAll(int fd) {
  std::string text;
  char buf[4096];
  for (;;) {
    const ssize_t n = read(fd, buf, sizeof(buf));
    if (n > 0) {
      text.append(buf, static_cast<std::size_t>(n));
    } else if (n == 0 || errno != EINTR) {
      return text;
    }
  }
}

void closeFd(int& fd) {
  if (fd >= 0) close(fd);
  fd = -1;
}

}  // namespace

PlotJob::PlotJob(const std::string& script) {
  if (script.empty()) {
    skipped_ = "report.png skipped: the plot script was not found";
    return;
  }
  if (!fs::exists(script)) {
    skipped_ = "report.png skipped: " + script + " does not exist";
    return;
  }
  int in[2] = {-1, -1}, err[2] = {-1, -1};
  if (pipe2(in, O_CLOEXEC) != 0 || pipe2(err, O_CLOEXEC) != 0) {
    for (int* fd : {&in[0], &in[1], &err[0], &err[1]}) closeFd(*fd);
    skipped_ = "report.png skipped: no pipe to the plot script";
    return;
  }
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, in[0], 0);
  posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_adddup2(&actions, err[1], 2);
  // Debian's interpreter, where the packaged matplotlib is, before whatever PATH puts first.
  const std::string python = fs::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
  std::vector<std::string> args = {python, script, "-"};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  const int spawned = posix_spawnp(&pid_, python.c_str(), &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  closeFd(in[0]);
  closeFd(err[1]);
  to_script_ = in[1];
  from_script_ = err[0];
  if (spawned != 0) {
    pid_ = -1;
    stop();
    skipped_ = "report.png skipped: python3 is not installed";
  }
}

PlotJob::~PlotJob() { stop(); }

void PlotJob::stop() {
  closeFd(to_script_);
  closeFd(from_script_);
  if (pid_ <= 0) return;
  kill(pid_, SIGTERM);
  int status = 0;
  while (waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
  }
  pid_ = -1;
}

void PlotJob::draw(const std::string& dir) {
  if (to_script_ < 0) return;
  dir_ = dir;
  writeToPipe(to_script_, dir + "\n");
  closeFd(to_script_);
}

std::string PlotJob::finish() {
  if (pid_ <= 0) return skipped_;
  closeFd(to_script_);  // a script never told a folder ends without drawing
  const std::string why = lastLine(readAll(from_script_));
  closeFd(from_script_);
  int status = 0;
  while (waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
  }
  pid_ = -1;
  if (WIFEXITED(status) && WEXITSTATUS(status) == 3) {
    return "report.png skipped: python3-matplotlib is not installed";
  }
  if (dir_.empty()) return "report.png skipped: the plot script was given no folder";
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0 && fs::exists(fs::path(dir_) / "report.png")) {
    return "";
  }
  return "report.png skipped: the plot script failed" + (why.empty() ? "" : ": " + why);
}

std::string findPlotScript() {
  const char* prefixes = std::getenv("CMAKE_PREFIX_PATH");
  std::string rest = prefixes != nullptr ? prefixes : "";
  while (!rest.empty()) {
    const auto colon = rest.find(':');
    const fs::path candidate = fs::path(rest.substr(0, colon)) / "lib/flexcloud/plot_report.py";
    if (fs::exists(candidate)) return candidate.string();
    rest = colon == std::string::npos ? "" : rest.substr(colon + 1);
  }
  const fs::path source = fs::path(FLEXCLOUD_SOURCE_DIR) / "scripts/plot_report.py";
  return fs::exists(source) ? source.string() : "";
}

}  // namespace flexcloud
