// Fuzz target: the text trajectory and GNSS readers. Any input must end in a result or a
// flexcloud::Error, never in a crash or undefined behaviour.
#include <cstdint>
#include <string>

#include "flexcloud/io/param_table.h"
#include "flexcloud/io/text_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace flexcloud;
  const std::string text(reinterpret_cast<const char*>(data), size);
  for (StampUnit unit : {StampUnit::kAuto, StampUnit::kSeconds, StampUnit::kNanoseconds}) {
    try {
      parseTum(text, "fuzz", unit);
    } catch (const Error&) {
    }
    try {
      parseGeodeticGnss(text, "fuzz", unit);
    } catch (const Error&) {
    }
    try {
      parseLocalGnss(text, "fuzz", unit);
    } catch (const Error&) {
    }
  }
  try {
    Params p;
    setParam(p, "excluded_ranges", text);
  } catch (const Error&) {
  }
  return 0;
}
