#include "flexcloud/io/pcd_ascii.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <type_traits>

#include "flexcloud/types.h"

namespace flexcloud {
namespace {

constexpr std::size_t kReadBytes = std::size_t{8} << 20;
constexpr std::size_t kSampleBytes = std::size_t{1} << 16;

/// The value of a whole token by std::from_chars (fast, correctly rounded); false where it
/// does not read the token whole (then the C library's reader, which also takes a leading '+'
/// and hexadecimal floats, decides).
template <typename T>
bool fastValue(std::string_view tok, T* v) {
#if !defined(__cpp_lib_to_chars)
  // libstdc++ before GCC 11 reads no double with from_chars: the C library's reader decides.
  if constexpr (std::is_floating_point_v<T>) {
    (void)tok, (void)v;
    return false;
  } else
#endif
  {
    const auto r = std::from_chars(tok.data(), tok.data() + tok.size(), *v);
    return r.ec == std::errc() && r.ptr == tok.data() + tok.size();
  }
}

/// A whole token as a double, long long or unsigned long long through the C library.
bool slowValue(std::string_view tok, char type, double* d, long long* i, unsigned long long* u) {
  char text[128];
  if (tok.size() >= sizeof(text)) return false;
  std::memcpy(text, tok.data(), tok.size());
  text[tok.size()] = '\0';
  char* end = nullptr;
  errno = 0;
  if (type == 'F') {
    *d = std::strtod(text, &end);
  } else if (type == 'I') {
    *i = std::strtoll(text, &end, 10);
  } else {
    if (text[0] == '-') return false;
    *u = std::strtoull(text, &end, 10);
  }
  return end != text && *end == '\0' && (type == 'F' || errno != ERANGE);
}

/// One ascii value into `out` as the field's binary type; false when it is not such a value.
bool parseValue(std::string_view tok, const PcdField& f, std::uint8_t* out) {
  double d = 0.0;
  long long i = 0;
  unsigned long long u = 0;
  if (f.type == 'F') {
    if (!fastValue(tok, &d) && !slowValue(tok, 'F', &d, &i, &u)) return false;
    if (f.size == 4) {
      if (std::isfinite(d) && std::abs(d) > std::numeric_limits<float>::max()) return false;
      const auto x = static_cast<float>(d);
      std::memcpy(out, &x, 4);
    } else {
      std::memcpy(out, &d, 8);
    }
    return true;
  }
  const unsigned bits = static_cast<unsigned>(8 * f.size);
  if (f.type == 'I') {
    if (!fastValue(tok, &i) && !slowValue(tok, 'I', &d, &i, &u)) return false;
    if (bits < 64 && (i < -(1LL << (bits - 1)) || i >= (1LL << (bits - 1)))) return false;
    std::memcpy(out, &i, f.size);  // little-endian: the low bytes
    return true;
  }
  if (!fastValue(tok, &u) && !slowValue(tok, 'U', &d, &i, &u)) return false;
  if (bits < 64 && u >= (1ULL << bits)) return false;
  std::memcpy(out, &u, f.size);
  return true;
}

/// White space as the C locale's isspace() has it, without a call per character.
inline bool blank(char c) { return c == ' ' || (c >= '\t' && c <= '\r'); }

void tokenize(std::string_view line, std::vector<std::string_view>& tokens) {
  tokens.clear();
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && blank(line[i])) ++i;
    const std::size_t j = i;
    while (i < line.size() && !blank(line[i])) ++i;
    if (i > j) tokens.push_back(line.substr(j, i - j));
  }
}

/// The tokens of one line as a point at dst; "" when they are one, else what is wrong.
std::string parsePoint(const std::vector<std::string_view>& tokens, const PcdHeader& h,
                       std::size_t values, std::uint8_t* dst) {
  if (tokens.size() != values) {
    return "expected " + std::to_string(values) + " values, found " + std::to_string(tokens.size());
  }
  std::size_t t = 0;
  for (const auto& f : h.fields) {
    for (std::size_t c = 0; c < f.count; ++c, ++t) {
      if (!parseValue(tokens[t], f, dst + f.offset + c * f.size)) {
        return "'" + std::string(tokens[t]) + "' is not a value of field " + f.name + " (" +
               std::string(1, f.type) + std::to_string(f.size) + ")";
      }
    }
  }
  return "";
}

/// Reads up to `bytes` at `offset`; returns how many (0 at the end of the file).
std::size_t readSome(int fd, char* out, std::size_t bytes, std::uint64_t offset,
                     const std::string& path) {
  for (;;) {
    const ssize_t n = ::pread(fd, out, bytes, static_cast<off_t>(offset));
    if (n >= 0) return static_cast<std::size_t>(n);
    if (errno != EINTR) throw Error(path + ": read failed: " + std::strerror(errno));
  }
}

}  // namespace

PcdAsciiReader::PcdAsciiReader(const std::string& path)
    : path_(path), header_(readPcdHeader(path)) {
  if (header_.data != PcdHeader::Data::kAscii) throw Error(path + ": not an ascii PCD");
  for (const auto& f : header_.fields) values_ += f.count;
  // A value is a number of at most a few dozen characters: a longer line is not a point, and
  // reading on to its end could take the whole file into memory.
  max_line_ = std::max<std::size_t>(std::size_t{1} << 20, 128 * values_);
  fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd_ < 0) throw Error(path + ": cannot open: " + std::strerror(errno));
  ::posix_fadvise(fd_, 0, 0, POSIX_FADV_SEQUENTIAL);
  file_pos_ = header_.data_offset;
  line_no_ = header_.header_lines;
}

PcdAsciiReader::~PcdAsciiReader() {
  if (fd_ >= 0) ::close(fd_);
}

bool PcdAsciiReader::nextLine(std::string_view* line) {
  for (;;) {
    const std::size_t nl = buffer_.find('\n', pos_);
    if (nl != std::string::npos || (eof_ && pos_ < buffer_.size())) {
      const std::size_t end = nl == std::string::npos ? buffer_.size() : nl;
      *line = std::string_view(buffer_).substr(pos_, end - pos_);
      pos_ = end + 1;
      return true;
    }
    if (eof_) return false;
    buffer_.erase(0, pos_);
    pos_ = 0;
    if (buffer_.size() > max_line_) {
      throw Error(path_ + ":" + std::to_string(line_no_ + 1) + ": a line longer than " +
                  std::to_string(max_line_) + " bytes is not a point");
    }
    const std::size_t have = buffer_.size();
    buffer_.resize(have + kReadBytes);
    const std::size_t n = readSome(fd_, buffer_.data() + have, kReadBytes, file_pos_, path_);
    buffer_.resize(have + n);
    file_pos_ += n;
    eof_ = n == 0;
  }
}

std::size_t PcdAsciiReader::read(std::uint8_t* buf, std::size_t max_points) {
  std::size_t n = 0;
  std::string_view line;
  while (n < max_points && nextLine(&line)) {
    ++line_no_;
    tokenize(line, tokens_);
    if (tokens_.empty()) continue;
    const auto where = [&] { return path_ + ":" + std::to_string(line_no_) + ": "; };
    if (points_ == header_.points) {
      throw Error(where() + "more points than the header's " + std::to_string(header_.points));
    }
    const std::string problem = parsePoint(tokens_, header_, values_, buf + n * header_.point_step);
    if (!problem.empty()) throw Error(where() + problem);
    ++points_;
    ++n;
  }
  if (n < max_points && points_ != header_.points) {  // the body ended
    throw Error(path_ + ": the ascii body holds " + std::to_string(points_) +
                " points, the header " + std::to_string(header_.points) + " (file cut short?)");
  }
  return n;
}

void PcdAsciiReader::sample(std::size_t blocks, std::size_t block, const PcdPointsFn& fn) const {
  const std::uint64_t body = header_.file_size - header_.data_offset;
  std::string window(kSampleBytes, '\0');
  std::vector<std::uint8_t> points(block * header_.point_step);
  std::vector<std::string_view> tokens;
  for (std::size_t k = 0; k < blocks && body > 0; ++k) {
    const std::uint64_t at = header_.data_offset + body * k / blocks;
    const std::size_t got = readSome(fd_, window.data(), window.size(), at, path_);
    std::string_view text(window.data(), got);
    if (k > 0) {  // from the first whole line on
      const std::size_t nl = text.find('\n');
      text = nl == std::string_view::npos ? std::string_view() : text.substr(nl + 1);
    }
    std::size_t n = 0;
    while (n < block && !text.empty()) {
      const std::size_t nl = text.find('\n');
      if (nl == std::string_view::npos && at + got < header_.file_size) break;  // cut off
      const std::string_view line = text.substr(0, nl);
      text = nl == std::string_view::npos ? std::string_view() : text.substr(nl + 1);
      tokenize(line, tokens);
      if (tokens.empty()) continue;
      if (parsePoint(tokens, header_, values_, points.data() + n * header_.point_step).empty()) ++n;
    }
    if (n > 0) fn(points.data(), n);
  }
}

}  // namespace flexcloud
