#pragma once
// Copying a binary map's body into its output in the kernel, on a thread of its own, ahead of
// the warp that works on the output in place. Private to the io library.

#include <sys/types.h>

#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

namespace flexcloud {

/// Closes a file descriptor on scope exit unless released.
struct FdGuard {
  int fd = -1;
  FdGuard() = default;
  explicit FdGuard(int f) : fd(f) {}
  FdGuard(const FdGuard&) = delete;
  FdGuard& operator=(const FdGuard&) = delete;
  ~FdGuard();
  int release();
};

/// Where a body lies and goes: `points` records of `step` bytes from in_offset of in_fd to
/// out_offset of out_fd, copied `chunk` points at a time. `name` names the output in errors.
struct BodyRange {
  int in_fd = -1, out_fd = -1;
  std::size_t in_offset = 0, out_offset = 0;
  std::size_t points = 0, step = 0, chunk = std::size_t{1} << 20;
  std::string name;
};

/// Copies a body chunk by chunk on its own thread; waitFor() blocks until a range is copied.
/// Destroyed early, it stops after the chunk in hand.
class BodyCopier {
 public:
  explicit BodyCopier(BodyRange range);
  ~BodyCopier();
  BodyCopier(const BodyCopier&) = delete;
  BodyCopier& operator=(const BodyCopier&) = delete;

  /// Waits until points [0, points) are copied; rethrows a failure of the copy.
  void waitFor(std::size_t points);
  /// Ends the copy thread; rethrows a failure of the copy. Returns the copy's seconds.
  double finish();

 private:
  void copyAll();
  void stop();

  BodyRange range_;
  std::mutex m_;
  std::condition_variable cv_;
  std::size_t copied_ = 0;  ///< points copied so far (guarded by m_)
  double seconds_ = 0.0;    ///< written by the copy thread, read after it ended
  std::exception_ptr error_;
  std::atomic<bool> stop_{false};
  std::thread thread_;  ///< last: starts once the members above exist
};

/// An output file being filled: its descriptor, the map's, and the copier between them
/// (destroyed first: it stops before the files close).
struct OutputBody {
  FdGuard out, in;
  std::unique_ptr<BodyCopier> copier;
};

/// Reserves `bytes` for the file open at fd; false where the filesystem cannot (a full disk then
/// shows before the warp, not in its middle). Throws Error naming `name` for another failure.
bool reserveSpace(int fd, std::size_t bytes, const std::string& name);

/// Writes all of `text` at offset 0; throws Error naming `name`.
void writeHeader(int fd, const std::string& text, const std::string& name);

struct PcdHeader;

/// The header of a binary map's output: the map's own fields and size, binary. The early copy
/// and the warp both place the body behind it.
std::string outputHeader(const PcdHeader& map);

/// Writes `header` into body.out (open, empty) after reserving room for the whole file, opens
/// map `in` and starts copying the body of `map` behind the header, `chunk` points at a time;
/// false, nothing written, where the filesystem cannot reserve the space. Throws Error naming
/// `name` (the output) or `in` for another failure.
bool startCopy(OutputBody& body, const std::string& in, const PcdHeader& map,
               const std::string& header, std::size_t chunk, const std::string& name);

/// Reads exactly `bytes` at `offset` of fd into buf; throws Error naming `name` on a failure or
/// a file shorter than that.
void readAt(int fd, std::uint8_t* buf, std::size_t bytes, off_t offset, const std::string& name);

/// Writes all `bytes` of buf at `offset` of fd; throws Error naming `name`.
void writeAt(int fd, const std::uint8_t* buf, std::size_t bytes, off_t offset,
             const std::string& name);

}  // namespace flexcloud
