#pragma once
// The staging folder a run's outputs are written into before they are moved into the output
// folder together: a folder never holds a half-done set, nor files of two runs.

#include <string>
#include <vector>

namespace flexcloud {

/// A folder `.flexcloud-staging-PID-N` inside the output folder, locked (flock) while its run
/// lives. Made, it first removes every staging folder no live run holds (one left by a run that
/// was killed); destroyed without commit(), it removes itself and the output folder if the run
/// created it.
class Staging {
 public:
  explicit Staging(const std::string& dir);
  ~Staging();
  Staging(const Staging&) = delete;
  Staging& operator=(const Staging&) = delete;

  const std::string& folder() const { return stage_; }
  /// The staged path of output `name`, to be moved into place by commit().
  std::string path(const std::string& name);
  /// Moves the staged outputs into place, `last` after all others (the file whose presence
  /// says the set is complete; its earlier copy is removed first), and removes every name of
  /// `outputs` this run did not write, so that the folder holds this run's outputs alone.
  /// Anything else in the folder is left alone.
  void commit(const std::string& last, const std::vector<std::string>& outputs);
  /// `message` with the staging folder's path replaced by the output folder's.
  std::string userMessage(std::string message) const;

 private:
  std::string dir_;
  std::string stage_;
  int lock_fd_ = -1;
  bool created_ = false;
  bool committed_ = false;
  std::vector<std::string> names_;
};

/// Removes the staging folders in `dir` that no live run holds; returns how many.
int removeAbandonedStaging(const std::string& dir);

}  // namespace flexcloud
