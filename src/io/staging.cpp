#include "staging.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "flexcloud/io/atomic_file.h"
#include "flexcloud/types.h"

namespace flexcloud {
namespace {

namespace fs = std::filesystem;

constexpr const char* kPrefix = ".flexcloud-staging-";
constexpr const char* kLock = ".lock";

/// Whether the run that made staging folder `stage` is gone: its lock is free, or (a folder
/// without a lock file, killed between the two) the process its name holds is no longer alive.
bool abandoned(const fs::path& stage) {
  const int fd = ::open((stage / kLock).c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    const std::string name = stage.filename().string().substr(std::strlen(kPrefix));
    const long pid = std::strtol(name.c_str(), nullptr, 10);
    return pid <= 0 || (::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH);
  }
  const bool free = ::flock(fd, LOCK_EX | LOCK_NB) == 0;
  ::close(fd);
  return free;
}

}  // namespace

int removeAbandonedStaging(const std::string& dir) {
  int removed = 0;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    if (e.path().filename().string().rfind(kPrefix, 0) != 0 || !e.is_directory(ec)) continue;
    if (!abandoned(e.path())) continue;
    fs::remove_all(e.path(), ec);
    removed += ec ? 0 : 1;
  }
  return removed;
}

Staging::Staging(const std::string& dir) : dir_(dir), created_(!fs::exists(dir)) {
  makeDirectories(dir);
  removeAbandonedStaging(dir);
  static std::atomic<int> counter{0};
  stage_ = (fs::path(dir) /
            (kPrefix + std::to_string(::getpid()) + "-" + std::to_string(counter.fetch_add(1))))
               .string();
  std::error_code ec;
  fs::remove_all(stage_, ec);
  if (!fs::create_directory(stage_, ec) || ec) {
    throw Error(dir + ": cannot write into the output folder: " +
                (ec ? ec.message() : std::string("the staging folder exists")));
  }
  lock_fd_ = ::open((fs::path(stage_) / kLock).c_str(), O_CREAT | O_RDWR | O_CLOEXEC, 0644);
  if (lock_fd_ < 0 || ::flock(lock_fd_, LOCK_EX | LOCK_NB) != 0) {
    const std::string why = std::strerror(errno);
    fs::remove_all(stage_, ec);
    throw Error(dir + ": cannot write into the output folder: " + why);
  }
}

Staging::~Staging() {
  std::error_code ec;
  fs::remove_all(stage_, ec);
  if (lock_fd_ >= 0) ::close(lock_fd_);
  if (created_ && !committed_) fs::remove(dir_, ec);  // only if empty: nothing else was there
}

std::string Staging::path(const std::string& name) {
  names_.push_back(name);
  return (fs::path(stage_) / name).string();
}

void Staging::commit(const std::string& last, const std::vector<std::string>& outputs) {
  std::error_code ec;
  fs::remove(fs::path(dir_) / last, ec);
  auto move = [&](const std::string& n) {
    const fs::path from = fs::path(stage_) / n;
    const fs::path to = fs::path(dir_) / n;
    if (fs::is_directory(from) && fs::exists(to)) fs::remove_all(to, ec);
    if (std::rename(from.c_str(), to.c_str()) != 0) {
      throw Error(to.string() +
                  ": cannot move the finished file into place: " + std::strerror(errno));
    }
  };
  for (const auto& n : names_) {
    if (n != last) move(n);
  }
  for (const auto& n : outputs) {
    if (std::find(names_.begin(), names_.end(), n) == names_.end()) {
      fs::remove_all(fs::path(dir_) / n, ec);
    }
  }
  if (std::find(names_.begin(), names_.end(), last) != names_.end()) move(last);
  committed_ = true;
}

std::string Staging::userMessage(std::string message) const {
  for (auto at = message.find(stage_); at != std::string::npos; at = message.find(stage_, at)) {
    message.replace(at, stage_.size(), dir_);
    at += dir_.size();
  }
  return message;
}

}  // namespace flexcloud
