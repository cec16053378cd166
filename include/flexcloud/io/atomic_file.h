#pragma once
// Output files that appear under their final name only when complete.

#include <fstream>
#include <string>

namespace flexcloud {

/// A file written under a temporary name in the same folder and renamed onto `path` by
/// commit(). Destroyed without commit (an error, an exception, a signal-driven exit), the
/// temporary file is removed and `path` is left as it was.
class AtomicFile {
 public:
  explicit AtomicFile(std::string path);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  /// The temporary path to write to (for writers that open files themselves).
  const std::string& tempPath() const { return temp_; }
  /// A stream on the temporary file (opened on first use). Throws Error if it cannot be opened.
  std::ofstream& stream();
  /// Flushes, checks for write errors, renames onto the final path. Throws Error on failure.
  void commit();

 private:
  std::string path_;
  std::string temp_;
  std::ofstream out_;
  bool committed_ = false;
};

/// Writes `text` to `path` atomically.
void writeTextFile(const std::string& path, const std::string& text);

/// Creates the folder (and parents); throws Error naming it if that fails.
void makeDirectories(const std::string& dir);

}  // namespace flexcloud
