#pragma once
// The body of a binary_compressed PCD read in chunks. Such a body is one LZF block (liblzf's
// format) of the whole cloud stored field after field: every point's x, then every point's y,
// and so on. LZF refers back at most 8 KiB, so a decoder needs only that much of its output:
// one pass over the block records a decoder at the start of each field's column, and each
// chunk of points is then decoded column by column from those decoders. Memory stays at a few
// small buffers per field whatever the cloud's size; the block is decoded about twice.

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "flexcloud/io/pcd_header.h"

namespace flexcloud {

/// Decodes an LZF block read from a file a piece at a time. A copy is a checkpoint: it goes on
/// from where the original stood.
class LzfDecoder {
 public:
  /// The block of `packed` bytes at `offset` of the open file `fd`, unpacking to `unpacked`
  /// bytes; `name` is used in messages.
  LzfDecoder(int fd, std::uint64_t offset, std::uint64_t packed, std::uint64_t unpacked,
             const std::string& name);
  /// The next n bytes of output into out (nullptr: passed over). Throws Error when the block
  /// is corrupt or ends before them.
  void read(std::uint8_t* out, std::uint64_t n);
  /// Whether every input byte was used and every output byte produced.
  bool done() const;

 private:
  void refill();
  std::uint8_t nextInput();
  /// Appends n bytes of output to the window and to out (unless nullptr).
  void put(std::uint8_t*& out, const std::uint8_t* bytes, std::size_t n);
  [[noreturn]] void corrupt() const;

  static constexpr std::size_t kWindow = 1 << 13;  // LZF's longest reference back
  static constexpr std::size_t kInput = 1 << 14;
  int fd_;
  std::string name_;
  std::uint64_t in_next_;  ///< file offset of the next byte to buffer
  std::uint64_t in_left_;  ///< input bytes not buffered yet
  std::uint64_t out_left_;
  std::uint64_t produced_ = 0;
  std::array<std::uint8_t, kInput> in_{};
  std::size_t in_pos_ = 0, in_len_ = 0;
  std::array<std::uint8_t, kWindow> window_{};
  std::uint64_t literal_ = 0;   ///< bytes of a literal run still to copy
  std::uint64_t copy_ = 0;      ///< bytes of a back reference still to copy
  std::uint64_t distance_ = 0;  ///< of that back reference
};

/// Sequential reads of a binary_compressed PCD's points, and a sample spread over the cloud.
class PcdCompressedReader {
 public:
  /// Checks the block's sizes against the header and finds where each field's column starts.
  /// Throws Error when the file is missing, is not DATA binary_compressed, or is corrupt.
  explicit PcdCompressedReader(const std::string& path);
  ~PcdCompressedReader();
  PcdCompressedReader(const PcdCompressedReader&) = delete;
  PcdCompressedReader& operator=(const PcdCompressedReader&) = delete;

  const PcdHeader& header() const { return header_; }
  /// Decodes the next up to `max_points` points into buf (point_step bytes each, the binary
  /// layout of the header); returns how many, 0 at the end.
  std::size_t read(std::uint8_t* buf, std::size_t max_points);

  /// Calls fn for `blocks` runs of up to `block` points spread evenly over the cloud, with
  /// only the fields x, y and z filled in (the rest zero): for placing the location grid.
  void sample(std::size_t blocks, std::size_t block, const PcdPointsFn& fn) const;

 private:
  std::string path_;
  PcdHeader header_;
  int fd_ = -1;
  std::vector<LzfDecoder> columns_;  ///< one per field of the header, at the next point
  std::vector<std::uint8_t> column_;
  std::size_t next_ = 0;
};

}  // namespace flexcloud
