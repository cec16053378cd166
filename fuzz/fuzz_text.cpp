// Fuzz target: the text trajectory and GNSS readers. Any input must end in a result or a
// flexcloud::Error, never in a crash or undefined behaviour.
#include <cstdint>
#include <string>

#include "flexcloud/io/text_io.h"
#include "flexcloud/params.h"

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
  Params p;
  for (const auto& row : paramTable().rows()) {
    try {
      paramTable().setText(p, row.spec.name, text);
    } catch (const Error&) {
    }
  }
  p.validate();
  return 0;
}
