#pragma once
// A mutex whose guarded members clang checks at compile time (-Wthread-safety): a member marked
// FLEXCLOUD_GUARDED_BY(m) read or written where `m` is not held is a compile error in the clang
// builds (the sanitizer and ThreadSanitizer workspaces build the ROS layer with
// -Werror=thread-safety). Other compilers see plain std::mutex and std::unique_lock.

#include <chrono>
#include <condition_variable>
#include <mutex>

#if defined(__clang__)
#define FLEXCLOUD_TSA(x) __attribute__((x))
#else
#define FLEXCLOUD_TSA(x)
#endif
#define FLEXCLOUD_GUARDED_BY(m) FLEXCLOUD_TSA(guarded_by(m))
#define FLEXCLOUD_REQUIRES(m) FLEXCLOUD_TSA(requires_capability(m))
#define FLEXCLOUD_EXCLUDES(m) FLEXCLOUD_TSA(locks_excluded(m))

namespace flexcloud {

class FLEXCLOUD_TSA(capability("mutex")) GuardedMutex {
 public:
  void lock() FLEXCLOUD_TSA(acquire_capability()) { m_.lock(); }
  void unlock() FLEXCLOUD_TSA(release_capability()) { m_.unlock(); }

 private:
  friend class GuardedLock;
  std::mutex m_;
};

/// Holds a GuardedMutex from construction to destruction (or to unlock()); waits on a
/// condition variable with the mutex released while waiting.
class FLEXCLOUD_TSA(scoped_lockable) GuardedLock {
 public:
  explicit GuardedLock(GuardedMutex& m) FLEXCLOUD_TSA(acquire_capability(m)) : lock_(m.m_) {}
  ~GuardedLock() FLEXCLOUD_TSA(release_capability()) = default;
  GuardedLock(const GuardedLock&) = delete;
  GuardedLock& operator=(const GuardedLock&) = delete;

  void unlock() FLEXCLOUD_TSA(release_capability()) { lock_.unlock(); }
  void wait(std::condition_variable& cv) { cv.wait(lock_); }
  void waitUntil(std::condition_variable& cv, std::chrono::steady_clock::time_point t) {
    cv.wait_until(lock_, t);
  }

 private:
  std::unique_lock<std::mutex> lock_;
};

}  // namespace flexcloud
