#pragma once
// A small command-line reader shared by the tools: every mistake is a one-line error.

#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

#include "flexcloud/types.h"

namespace flexcloud::cli {

/// Thrown for a usage mistake (exit code 2).
class UsageError : public Error {
 public:
  using Error::Error;
};

class Args {
 public:
  Args(int argc, char** argv) : args_(argv + 1, argv + argc) {}
  bool done() const { return pos_ >= args_.size(); }
  std::string flag() { return args_[pos_++]; }
  /// The next argument as the value of `option`.
  std::string text(const std::string& option) {
    if (done()) throw UsageError(option + " needs a value");
    return args_[pos_++];
  }
  double number(const std::string& option) {
    const std::string t = text(option);
    char* end = nullptr;
    const double v = std::strtod(t.c_str(), &end);
    if (t.empty() || *end != '\0' || !std::isfinite(v)) {
      throw UsageError(option + ": '" + t + "' is not a number");
    }
    return v;
  }
  long integer(const std::string& option) {
    const double v = number(option);
    if (v != std::floor(v) || std::abs(v) > 2e9) {
      throw UsageError(option + ": '" + std::to_string(v) + "' is not an integer");
    }
    return static_cast<long>(v);
  }

 private:
  std::vector<std::string> args_;
  std::size_t pos_ = 0;
};

}  // namespace flexcloud::cli
