#pragma once
// The names of the Params fields and how to set each from text or numbers: one table shared by
// the YAML config, the command line and rosparam, so a key is spelled in one place.

#include <string>
#include <vector>

#include "flexcloud/params.h"

namespace flexcloud {

struct ParamRef {
  enum class Kind { kDouble, kInt, kInterpolation };
  std::string name;
  Kind kind;
  double* d = nullptr;
  int* i = nullptr;
  InterpolationMode* mode = nullptr;
};

/// Every scalar field of `p` (excluded_ranges is a list and handled by each loader).
std::vector<ParamRef> paramRefs(Params& p);

/// Sets field `name` of `p` from text; throws Error naming the key when the key is unknown or
/// the text is not a value of the field's type.
void setParam(Params& p, const std::string& name, const std::string& value);

/// Parses "begin:end[,begin:end...]" (seconds) into time ranges; throws Error otherwise.
std::vector<TimeRange> parseRanges(const std::string& text);

}  // namespace flexcloud
