#pragma once
// A small command-line reader shared by the tools: every mistake is a one-line error.

#include <cmath>
#include <cstdlib>
#include <iostream>
#include <string>
#include <utility>
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

/// The items of a comma-separated list, e.g. "1,2,3".
inline std::vector<std::string> items(const std::string& text) {
  std::vector<std::string> out;
  std::string item;
  for (char c : text) {
    if (c == ',') {
      out.push_back(item);
      item.clear();
    } else {
      item += c;
    }
  }
  if (!item.empty()) out.push_back(item);
  return out;
}

/// True for -h and --help, after printing `usage`.
inline bool printedHelp(const std::string& flag, const char* usage) {
  if (flag != "-h" && flag != "--help") return false;
  std::cout << usage;
  return true;
}

/// Reads every flag of the command line: -h / --help prints `usage` and exits 0; any other goes
/// to `take(flag, args)`, which reads the flag's values from `args` and returns false for a
/// flag it does not know (a UsageError naming it).
template <class Take>
void forEachFlag(int argc, char** argv, const char* usage, Take take) {
  Args a(argc, argv);
  while (!a.done()) {
    const std::string f = a.flag();
    if (printedHelp(f, usage)) std::exit(0);
    if (!take(f, a)) throw UsageError("unknown option '" + f + "'");
  }
}

/// KEY and VALUE of the value "KEY=VALUE" of `flag` (e.g. --set).
inline std::pair<std::string, std::string> keyValue(const std::string& flag,
                                                    const std::string& text) {
  const auto eq = text.find('=');
  if (eq == std::string::npos || eq == 0) {
    throw UsageError(flag + ": '" + text + "' is not KEY=VALUE");
  }
  return {text.substr(0, eq), text.substr(eq + 1)};
}

}  // namespace flexcloud::cli
