#pragma once
// A strict reader of PCD headers. PCL's own reader trusts the header (a text file that starts
// with '#' crashes it), so every file is checked here before its body is read.

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace flexcloud {

struct PcdField {
  std::string name;
  std::size_t size = 0;  ///< bytes per element: 1, 2, 4, 8
  char type = 'F';       ///< I, U or F
  std::size_t count = 1;
  std::size_t offset = 0;  ///< in the packed point
};

struct PcdHeader {
  enum class Data { kAscii, kBinary, kBinaryCompressed };
  std::vector<PcdField> fields;
  std::size_t width = 0;
  std::size_t height = 1;
  std::size_t points = 0;
  std::size_t point_step = 0;  ///< packed size of one point (sum of size * count)
  Data data = Data::kBinary;
  std::size_t data_offset = 0;   ///< byte where the body starts
  std::size_t header_lines = 0;  ///< lines before the body (for line numbers in body errors)
  std::uint64_t file_size = 0;
};

/// Receives `n` points in the binary layout of a header (point_step bytes each): how the
/// streamed readers hand over a sample of a map.
using PcdPointsFn = std::function<void(const std::uint8_t* points, std::size_t n)>;

/// Parses and checks the header of a PCD file: known keywords, consistent field lists, types
/// and sizes, WIDTH * HEIGHT == POINTS, a body long enough for binary data. Throws Error
/// "FILE: ..." (with the line where it applies) otherwise.
PcdHeader readPcdHeader(const std::string& path);

/// The same on bytes already in memory (the start of a file); `name` is used in messages.
PcdHeader parsePcdHeader(const std::string& bytes, const std::string& name,
                         std::uint64_t file_size);

}  // namespace flexcloud
