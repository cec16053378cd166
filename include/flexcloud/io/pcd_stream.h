#pragma once
// Binary PCD bodies read and written in chunks with plain read()/write(): no memory map, no copy
// beyond the caller's buffer, any size. ASCII and compressed bodies are read in chunks by
// pcd_ascii.h and pcd_compressed.h.

#include <pcl/PCLPointCloud2.h>

#include <cstdint>
#include <string>
#include <vector>

#include "flexcloud/io/atomic_file.h"
#include "flexcloud/io/pcd_header.h"

namespace flexcloud {

/// PCL fields of a header, offsets as in the file; padding fields ("_") are left out, as PCL does.
std::vector<pcl::PCLPointField> pclFields(const PcdHeader& header);

/// Header text of a binary PCD for these fields; gaps between fields (and at the end of the
/// point) become "_" padding fields, so the body is the points' bytes as they are in memory.
std::string binaryPcdHeader(const std::vector<pcl::PCLPointField>& fields, std::size_t point_step,
                            std::uint32_t width, std::uint32_t height);

/// Sequential and random reads of a binary PCD's points.
class PcdChunkReader {
 public:
  /// Throws Error when the file is missing, its header is bad, or it is not DATA binary.
  explicit PcdChunkReader(const std::string& path);
  ~PcdChunkReader();
  PcdChunkReader(const PcdChunkReader&) = delete;
  PcdChunkReader& operator=(const PcdChunkReader&) = delete;

  const PcdHeader& header() const { return header_; }
  /// Reads the next up to `max_points` points into buf; returns how many (0 at the end).
  std::size_t read(std::uint8_t* buf, std::size_t max_points);
  /// Reads `count` points from point `first` on, without moving the sequential position.
  void readAt(std::size_t first, std::size_t count, std::uint8_t* buf) const;

 private:
  std::string path_;
  PcdHeader header_;
  int fd_ = -1;
  std::size_t next_ = 0;
};

/// Writes a binary PCD under a temporary name; commit() checks the point count and renames it.
class PcdChunkWriter {
 public:
  PcdChunkWriter(const std::string& path, const std::vector<pcl::PCLPointField>& fields,
                 std::size_t point_step, std::uint32_t width, std::uint32_t height);
  ~PcdChunkWriter();
  PcdChunkWriter(const PcdChunkWriter&) = delete;
  PcdChunkWriter& operator=(const PcdChunkWriter&) = delete;

  void write(const std::uint8_t* buf, std::size_t points);
  void commit();

 private:
  void writeAll(const void* data, std::size_t bytes);

  std::string path_;
  AtomicFile file_;
  int fd_ = -1;
  std::size_t point_step_;
  std::size_t expected_;
  std::size_t written_ = 0;
};

}  // namespace flexcloud
