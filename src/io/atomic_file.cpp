#include "flexcloud/io/atomic_file.h"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "flexcloud/types.h"

namespace flexcloud {

AtomicFile::AtomicFile(std::string path) : path_(std::move(path)) {
  const std::filesystem::path p(path_);
  temp_ =
      (p.parent_path() / ("." + p.filename().string() + ".partial-" + std::to_string(::getpid())))
          .string();
}

AtomicFile::~AtomicFile() {
  if (!committed_) {
    if (out_.is_open()) out_.close();
    std::remove(temp_.c_str());
  }
}

std::ofstream& AtomicFile::stream() {
  if (!out_.is_open()) {
    out_.open(temp_, std::ios::out | std::ios::trunc | std::ios::binary);
    if (!out_) throw Error(path_ + ": cannot open for writing: " + std::strerror(errno));
  }
  return out_;
}

void AtomicFile::commit() {
  if (out_.is_open()) {
    out_.flush();
    const bool ok = static_cast<bool>(out_);
    out_.close();
    if (!ok) throw Error(path_ + ": write failed (disk full?)");
  }
  if (std::rename(temp_.c_str(), path_.c_str()) != 0) {
    throw Error(path_ + ": cannot move the finished file into place: " + std::strerror(errno));
  }
  committed_ = true;
}

void writeTextFile(const std::string& path, const std::string& text) {
  AtomicFile file(path);
  file.stream() << text;
  file.commit();
}

void makeDirectories(const std::string& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec || !std::filesystem::is_directory(dir)) {
    throw Error(dir + ": cannot create output folder: " +
                (ec ? ec.message() : std::string("not a folder")));
  }
}

}  // namespace flexcloud
