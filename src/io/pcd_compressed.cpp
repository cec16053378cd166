#include "flexcloud/io/pcd_compressed.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "flexcloud/types.h"

namespace flexcloud {
namespace {

/// Reads exactly `bytes` at `offset`; throws naming the file when it cannot.
void readExactly(int fd, std::uint8_t* out, std::size_t bytes, std::uint64_t offset,
                 const std::string& name) {
  while (bytes > 0) {
    const ssize_t n = ::pread(fd, out, bytes, static_cast<off_t>(offset));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      throw Error(name + ": read failed at byte " + std::to_string(offset) +
                  (n < 0 ? std::string(": ") + std::strerror(errno) : " (file cut short?)"));
    }
    out += n;
    offset += static_cast<std::uint64_t>(n);
    bytes -= static_cast<std::size_t>(n);
  }
}

}  // namespace

LzfDecoder::LzfDecoder(int fd, std::uint64_t offset, std::uint64_t packed, std::uint64_t unpacked,
                       const std::string& name)
    : fd_(fd), name_(name), in_next_(offset), in_left_(packed), out_left_(unpacked) {}

void LzfDecoder::corrupt() const { throw Error(name_ + ": the compressed body is corrupt"); }

void LzfDecoder::refill() {
  if (in_left_ == 0) corrupt();  // a token runs past the block's end
  in_len_ = static_cast<std::size_t>(std::min<std::uint64_t>(in_.size(), in_left_));
  readExactly(fd_, in_.data(), in_len_, in_next_, name_);
  in_next_ += in_len_;
  in_left_ -= in_len_;
  in_pos_ = 0;
}

std::uint8_t LzfDecoder::nextInput() {
  if (in_pos_ == in_len_) refill();
  return in_[in_pos_++];
}

void LzfDecoder::put(std::uint8_t*& out, const std::uint8_t* bytes, std::size_t n) {
  if (n > out_left_) corrupt();            // more output than the header's points hold
  for (std::size_t done = 0; done < n;) {  // into the window, wrapping at its end
    const std::size_t at = produced_ % kWindow;
    const std::size_t k = std::min(n - done, kWindow - at);
    std::memcpy(window_.data() + at, bytes + done, k);
    produced_ += k;
    done += k;
  }
  out_left_ -= n;
  if (out != nullptr) {
    std::memcpy(out, bytes, n);
    out += n;
  }
}

void LzfDecoder::read(std::uint8_t* out, std::uint64_t n) {
  std::uint8_t ref[264];  // the longest back reference
  while (n > 0) {
    if (literal_ > 0) {
      if (in_pos_ == in_len_) refill();
      const std::size_t k = static_cast<std::size_t>(
          std::min<std::uint64_t>({literal_, n, static_cast<std::uint64_t>(in_len_ - in_pos_)}));
      put(out, in_.data() + in_pos_, k);
      in_pos_ += k;
      literal_ -= k, n -= k;
    } else if (copy_ > 0) {
      // Into a scratch first (the window is written by put()); a reference shorter than its
      // distance is one or two blocks of the window, a longer one repeats the bytes it makes.
      const std::size_t k = static_cast<std::size_t>(std::min<std::uint64_t>(copy_, n));
      const std::size_t from = (produced_ - distance_) % kWindow;
      if (k <= distance_) {
        const std::size_t first = std::min(k, kWindow - from);
        std::memcpy(ref, window_.data() + from, first);
        std::memcpy(ref + first, window_.data(), k - first);
      } else {
        for (std::size_t i = 0; i < k; ++i) {
          ref[i] = i < distance_ ? window_[(from + i) % kWindow] : ref[i - distance_];
        }
      }
      put(out, ref, k);
      copy_ -= k, n -= k;
    } else {
      const unsigned ctrl = nextInput();
      if (ctrl < 32) {  // a run of ctrl + 1 literal bytes
        literal_ = ctrl + 1;
        continue;
      }
      std::uint64_t length = ctrl >> 5;  // a back reference: length - 2, distance - 1
      if (length == 7) length += nextInput();
      const std::uint64_t distance = ((ctrl & 0x1fu) << 8) + nextInput() + 1;
      if (distance > produced_) corrupt();  // before the first byte
      copy_ = length + 2;
      distance_ = distance;
    }
  }
}

bool LzfDecoder::done() const {
  return out_left_ == 0 && literal_ == 0 && copy_ == 0 && in_pos_ == in_len_ && in_left_ == 0;
}

PcdCompressedReader::PcdCompressedReader(const std::string& path)
    : path_(path), header_(readPcdHeader(path)) {
  if (header_.data != PcdHeader::Data::kBinaryCompressed) {
    throw Error(path + ": not a binary_compressed PCD");
  }
  fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd_ < 0) throw Error(path + ": cannot open: " + std::strerror(errno));
  if (header_.points == 0) return;
  std::uint32_t sizes[2];  // packed, unpacked (the header check found them there)
  readExactly(fd_, reinterpret_cast<std::uint8_t*>(sizes), sizeof(sizes), header_.data_offset,
              path);
  const std::uint64_t expected = static_cast<std::uint64_t>(header_.points) * header_.point_step;
  if (sizes[1] != expected) {
    throw Error(path + ": the compressed body unpacks to " + std::to_string(sizes[1]) +
                " bytes, the header needs " + std::to_string(expected));
  }
  if (sizes[0] > header_.file_size - header_.data_offset - sizeof(sizes)) {
    throw Error(path + ": the compressed body is shorter than it says (file cut short?)");
  }
  LzfDecoder d(fd_, header_.data_offset + sizeof(sizes), sizes[0], sizes[1], path);
  for (const auto& f : header_.fields) {
    columns_.push_back(d);
    d.read(nullptr, static_cast<std::uint64_t>(f.size) * f.count * header_.points);
  }
  if (!d.done()) throw Error(path + ": the compressed body is corrupt");
}

PcdCompressedReader::~PcdCompressedReader() {
  if (fd_ >= 0) ::close(fd_);
}

std::size_t PcdCompressedReader::read(std::uint8_t* buf, std::size_t max_points) {
  const std::size_t n = std::min(max_points, header_.points - next_);
  for (std::size_t k = 0; k < header_.fields.size() && n > 0; ++k) {
    const PcdField& f = header_.fields[k];
    const std::size_t bytes = f.size * f.count;
    column_.resize(n * bytes);
    columns_[k].read(column_.data(), column_.size());
    for (std::size_t i = 0; i < n; ++i) {
      std::memcpy(buf + i * header_.point_step + f.offset, column_.data() + i * bytes, bytes);
    }
  }
  next_ += n;
  return n;
}

void PcdCompressedReader::sample(std::size_t blocks, std::size_t block,
                                 const PcdPointsFn& fn) const {
  // The decoders of the x, y and z columns, from where read() has got to.
  std::vector<std::pair<const PcdField*, LzfDecoder>> axes;
  for (const char* name : {"x", "y", "z"}) {
    for (std::size_t k = 0; k < header_.fields.size(); ++k) {
      if (header_.fields[k].name == name) axes.emplace_back(&header_.fields[k], columns_[k]);
    }
  }
  const std::size_t left = header_.points - next_;
  block = std::min(block, left);
  if (axes.size() != 3 || block == 0) return;
  std::vector<std::uint8_t> points(block * header_.point_step, 0);
  std::vector<std::uint8_t> values;
  std::size_t at = 0;  // points passed over so far
  for (std::size_t k = 0; k < blocks; ++k) {
    const std::size_t first = (left - block) * k / std::max<std::size_t>(1, blocks - 1);
    if (first < at) continue;
    for (auto& [f, d] : axes) {
      const std::size_t bytes = f->size * f->count;
      d.read(nullptr, (first - at) * bytes);
      values.resize(block * bytes);
      d.read(values.data(), values.size());
      for (std::size_t i = 0; i < block; ++i) {
        std::memcpy(points.data() + i * header_.point_step + f->offset, values.data() + i * bytes,
                    bytes);
      }
    }
    at = first + block;
    fn(points.data(), block);
  }
}

}  // namespace flexcloud
