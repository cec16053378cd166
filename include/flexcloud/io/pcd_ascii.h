#pragma once
// The body of an ascii PCD read strictly and in chunks: each line becomes one point in the
// binary layout of the header (the layout the binary reader gives), with a message that names
// the file and line for anything that is not a value of its field. Memory stays at one read
// buffer whatever the file's size.

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "flexcloud/io/pcd_header.h"

namespace flexcloud {

/// Sequential reads of an ascii PCD's points, and a sample spread over the whole file.
class PcdAsciiReader {
 public:
  /// Throws Error when the file is missing, its header is bad, or it is not DATA ascii.
  explicit PcdAsciiReader(const std::string& path);
  ~PcdAsciiReader();
  PcdAsciiReader(const PcdAsciiReader&) = delete;
  PcdAsciiReader& operator=(const PcdAsciiReader&) = delete;

  const PcdHeader& header() const { return header_; }
  /// Parses the next up to `max_points` points into buf (point_step bytes each); returns how
  /// many, 0 at the end. Throws Error "FILE:LINE: ..." for a bad line or a point beyond the
  /// header's count, and at the end when the body holds fewer points than the header says.
  std::size_t read(std::uint8_t* buf, std::size_t max_points);

  /// Calls fn for up to `blocks` runs of up to `block` points read at byte offsets spread
  /// evenly over the body (lines that do not parse are passed over: read() reports them with
  /// their line number). For placing the location grid; not the points' file order.
  void sample(std::size_t blocks, std::size_t block, const PcdPointsFn& fn) const;

 private:
  bool nextLine(std::string_view* line);

  std::string path_;
  PcdHeader header_;
  int fd_ = -1;
  std::size_t values_ = 0;    ///< values per line
  std::size_t max_line_ = 0;  ///< longest line accepted, bytes
  std::string buffer_;        ///< bytes read and not yet parsed start at pos_
  std::size_t pos_ = 0;
  std::uint64_t file_pos_ = 0;  ///< next byte to read
  bool eof_ = false;
  std::size_t line_no_ = 0;  ///< of the line last parsed, counted from the file's first
  std::size_t points_ = 0;   ///< points parsed so far
  std::vector<std::string_view> tokens_;
};

}  // namespace flexcloud
