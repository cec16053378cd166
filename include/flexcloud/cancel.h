#pragma once
// A cancel token: whoever starts a long run (the command-line tool on a signal, the ROS node on
// unload) owns one and hands it to the map warp, the stream and the output writer, which stop
// with Error at their next check. No process-wide flag.

#include <atomic>
#include <string>

#include "flexcloud/types.h"

namespace flexcloud {

class CancelToken {
 public:
  /// Asks every run holding this token to stop; safe from a signal handler.
  void cancel() { cancelled_.store(true, std::memory_order_relaxed); }
  /// Makes the token usable for the next run.
  void reset() { cancelled_.store(false, std::memory_order_relaxed); }
  bool cancelled() const { return cancelled_.load(std::memory_order_relaxed); }
  /// Throws Error("WHAT: cancelled") once cancel() was called.
  void check(const std::string& what) const {
    if (cancelled()) throw Error(what + ": cancelled");
  }

 private:
  std::atomic<bool> cancelled_{false};
};

static_assert(std::atomic<bool>::is_always_lock_free, "cancel() must be signal-safe");

/// A token that is never cancelled, for callers that do not cancel.
inline const CancelToken& neverCancelled() {
  static const CancelToken token;
  return token;
}

}  // namespace flexcloud
