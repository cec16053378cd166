#include "flexcloud/io/pcd_stream.h"

#include <fcntl.h>
#include <pcl/pcl_config.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <sstream>

#include "flexcloud/types.h"

namespace flexcloud {
namespace {

// PCL's datatypes of 64-bit integers (PCLPointField::INT64 and UINT64 from PCL 1.13 on; the
// same numbers kept here for the PCL of Ubuntu 20.04 and Debian 11, which has none: the PCD
// reader and writer are flexcloud's own, and a ROS PointCloud2 carries no such field).
constexpr std::uint8_t kInt64 = 9, kUInt64 = 10;
#if PCL_VERSION_COMPARE(>=, 1, 13, 0)
static_assert(kInt64 == pcl::PCLPointField::INT64 && kUInt64 == pcl::PCLPointField::UINT64);
#endif

std::uint8_t pclType(char type, std::size_t size) {
  using F = pcl::PCLPointField;
  switch (type) {
    case 'F':
      return size == 8 ? F::FLOAT64 : F::FLOAT32;
    case 'I':
      return size == 1 ? F::INT8 : size == 2 ? F::INT16 : size == 4 ? F::INT32 : kInt64;
    default:
      return size == 1 ? F::UINT8 : size == 2 ? F::UINT16 : size == 4 ? F::UINT32 : kUInt64;
  }
}

/// PCD TYPE and SIZE of a PCL datatype; throws for a type PCD cannot hold.
std::pair<char, std::size_t> pcdType(std::uint8_t datatype, const std::string& name) {
  using F = pcl::PCLPointField;
  switch (datatype) {
    case F::INT8:
      return {'I', 1};
    case F::UINT8:
      return {'U', 1};
    case F::INT16:
      return {'I', 2};
    case F::UINT16:
      return {'U', 2};
    case F::INT32:
      return {'I', 4};
    case F::UINT32:
      return {'U', 4};
    case F::FLOAT32:
      return {'F', 4};
    case F::FLOAT64:
      return {'F', 8};
    case kInt64:
      return {'I', 8};
    case kUInt64:
      return {'U', 8};
    default:
      throw Error("field " + name + ": datatype " + std::to_string(datatype) +
                  " cannot be written to PCD");
  }
}

}  // namespace

std::vector<pcl::PCLPointField> pclFields(const PcdHeader& h) {
  std::vector<pcl::PCLPointField> out;
  for (const auto& f : h.fields) {
    if (f.name == "_") continue;
    pcl::PCLPointField p;
    p.name = f.name;
    p.offset = static_cast<std::uint32_t>(f.offset);
    p.datatype = pclType(f.type, f.size);
    p.count = static_cast<std::uint32_t>(f.count);
    out.push_back(p);
  }
  return out;
}

std::string binaryPcdHeader(const std::vector<pcl::PCLPointField>& fields, std::size_t point_step,
                            std::uint32_t width, std::uint32_t height) {
  std::vector<pcl::PCLPointField> sorted = fields;
  std::sort(sorted.begin(), sorted.end(),
            [](const auto& a, const auto& b) { return a.offset < b.offset; });
  std::ostringstream names, sizes, types, counts;
  std::size_t at = 0;
  auto pad = [&](std::size_t bytes) {
    names << " _";
    sizes << " 1";
    types << " U";
    counts << ' ' << bytes;
  };
  for (const auto& f : sorted) {
    const auto [type, size] = pcdType(f.datatype, f.name);
    if (f.offset < at) throw Error("field " + f.name + " overlaps the field before it");
    if (f.offset > at) pad(f.offset - at);
    const std::size_t count = std::max<std::uint32_t>(1, f.count);
    names << ' ' << f.name;
    sizes << ' ' << size;
    types << ' ' << type;
    counts << ' ' << count;
    at = f.offset + size * count;
  }
  if (at > point_step) throw Error("the fields need more bytes than the point step");
  if (at < point_step) pad(point_step - at);
  std::ostringstream h;
  h << "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS" << names.str() << "\nSIZE"
    << sizes.str() << "\nTYPE" << types.str() << "\nCOUNT" << counts.str() << "\nWIDTH " << width
    << "\nHEIGHT " << height << "\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS "
    << static_cast<std::uint64_t>(width) * height << "\nDATA binary\n";
  return h.str();
}

PcdChunkReader::PcdChunkReader(const std::string& path)
    : path_(path), header_(readPcdHeader(path)) {
  if (header_.data != PcdHeader::Data::kBinary) {
    throw Error(path + ": not a binary PCD (chunked reading needs DATA binary)");
  }
  fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd_ < 0) throw Error(path + ": cannot open: " + std::strerror(errno));
  ::posix_fadvise(fd_, 0, 0, POSIX_FADV_SEQUENTIAL);
}

PcdChunkReader::~PcdChunkReader() {
  if (fd_ >= 0) ::close(fd_);
}

void PcdChunkReader::readAt(std::size_t first, std::size_t count, std::uint8_t* buf) const {
  std::size_t bytes = count * header_.point_step;
  auto offset = static_cast<off_t>(header_.data_offset + first * header_.point_step);
  while (bytes > 0) {
    const ssize_t n = ::pread(fd_, buf, bytes, offset);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      throw Error(
          path_ + ": read failed at byte " + std::to_string(offset) +
          (n < 0 ? std::string(": ") + std::strerror(errno) : std::string(" (file cut short?)")));
    }
    buf += n;
    offset += n;
    bytes -= static_cast<std::size_t>(n);
  }
}

std::size_t PcdChunkReader::read(std::uint8_t* buf, std::size_t max_points) {
  const std::size_t count = std::min(max_points, header_.points - next_);
  readAt(next_, count, buf);
  next_ += count;
  return count;
}

PcdChunkWriter::PcdChunkWriter(const std::string& path,
                               const std::vector<pcl::PCLPointField>& fields,
                               std::size_t point_step, std::uint32_t width, std::uint32_t height)
    : path_(path),
      file_(path),
      point_step_(point_step),
      expected_(static_cast<std::size_t>(width) * height) {
  const std::string header = binaryPcdHeader(fields, point_step, width, height);
  fd_ = ::open(file_.tempPath().c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd_ < 0) throw Error(path + ": cannot open for writing: " + std::strerror(errno));
  writeAll(header.data(), header.size());
}

PcdChunkWriter::~PcdChunkWriter() {
  if (fd_ >= 0) ::close(fd_);
}

void PcdChunkWriter::writeAll(const void* data, std::size_t bytes) {
  const auto* p = static_cast<const std::uint8_t*>(data);
  while (bytes > 0) {
    const ssize_t n = ::write(fd_, p, bytes);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) throw Error(path_ + ": write failed: " + std::strerror(errno));
    p += n;
    bytes -= static_cast<std::size_t>(n);
  }
}

void PcdChunkWriter::write(const std::uint8_t* buf, std::size_t points) {
  if (written_ + points > expected_) throw Error(path_ + ": more points written than declared");
  writeAll(buf, points * point_step_);
  written_ += points;
}

void PcdChunkWriter::commit() {
  if (written_ != expected_) {
    throw Error(path_ + ": " + std::to_string(written_) + " of " + std::to_string(expected_) +
                " points written");
  }
  const int fd = fd_;
  fd_ = -1;
  if (::close(fd) != 0) throw Error(path_ + ": write failed: " + std::strerror(errno));
  file_.commit();
}

}  // namespace flexcloud
