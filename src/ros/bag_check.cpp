#include "flexcloud/ros/bag_check.h"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <map>
#include <set>
#include <vector>

#include "flexcloud/types.h"

namespace flexcloud {
namespace {

constexpr char kMagic[] = "#ROSBAG V2.0\n";
constexpr std::uint64_t kMaxHeader = 1ull << 26;  // 64 MiB of record header is no real bag
constexpr std::uint64_t kMaxChunk = 1ull << 31;

/// Bounds-checked reading of little-endian values from a byte range.
class Cursor {
 public:
  Cursor(const std::uint8_t* p, std::size_t n) : p_(p), end_(p + n) {}
  std::size_t left() const { return static_cast<std::size_t>(end_ - p_); }
  bool u32(std::uint32_t& v) { return take(&v, 4); }
  bool skip(std::size_t n) {
    if (n > left()) return false;
    p_ += n;
    return true;
  }
  const std::uint8_t* here() const { return p_; }

 private:
  bool take(void* v, std::size_t n) {
    if (n > left()) return false;
    std::memcpy(v, p_, n);
    p_ += n;
    return true;
  }
  const std::uint8_t* p_;
  const std::uint8_t* end_;
};

using Fields = std::map<std::string, std::string>;

/// name=value fields, each prefixed by its length; false if one overruns the header.
bool parseFields(const std::uint8_t* p, std::size_t n, Fields& out) {
  Cursor c(p, n);
  while (c.left() > 0) {
    std::uint32_t len = 0;
    if (!c.u32(len) || len > c.left()) return false;
    const std::string field(reinterpret_cast<const char*>(c.here()), len);
    c.skip(len);
    const auto eq = field.find('=');
    if (eq == std::string::npos) return false;
    out[field.substr(0, eq)] = field.substr(eq + 1);
  }
  return true;
}

std::uint64_t number(const Fields& f, const std::string& name) {
  const auto it = f.find(name);
  if (it == f.end() || it->second.empty() || it->second.size() > 8) return 0;
  std::uint64_t v = 0;
  std::memcpy(&v, it->second.data(), it->second.size());
  return v;
}

/// The records inside an uncompressed chunk; returns where each starts (offsets in the chunk).
std::set<std::uint64_t> checkChunk(const std::string& path, const std::uint8_t* p, std::size_t n,
                                   std::uint64_t at) {
  std::set<std::uint64_t> starts;
  Cursor c(p, n);
  while (c.left() > 0) {
    starts.insert(n - c.left());
    const std::string where = path + ": record in the chunk at byte " + std::to_string(at);
    std::uint32_t hlen = 0, dlen = 0;
    if (!c.u32(hlen) || hlen > c.left()) throw Error(where + " has a header longer than the chunk");
    Fields f;
    if (!parseFields(c.here(), hlen, f)) throw Error(where + " has a malformed header");
    c.skip(hlen);
    if (!c.u32(dlen) || dlen > c.left()) throw Error(where + " has data longer than the chunk");
    const auto op = f.find("op");
    if (op == f.end() || op->second.size() != 1 ||
        (op->second[0] != 0x02 && op->second[0] != 0x07)) {
      throw Error(where + " is neither a message nor a connection");
    }
    if (op->second[0] == 0x07) {
      Fields conn;
      if (!parseFields(c.here(), dlen, conn)) throw Error(where + ": malformed connection");
    }
    c.skip(dlen);
  }
  return starts;
}

/// One pass over a bag's records, checking each against the file and the others.
class BagScan {
 public:
  explicit BagScan(const std::string& path)
      : path_(path), in_(path, std::ios::binary | std::ios::ate) {
    if (!in_) throw Error(path + ": cannot open: " + std::strerror(errno));
    size_ = static_cast<std::uint64_t>(in_.tellg());
    in_.seekg(0);
    char magic[sizeof(kMagic) - 1] = {};
    in_.read(magic, sizeof(magic));
    if (!in_ || std::memcmp(magic, kMagic, sizeof(magic)) != 0) {
      throw Error(path + ": not a rosbag (version 2.0) file");
    }
    at_ = sizeof(magic);
  }

  void run() {
    while (at_ < size_) {
      records_.insert(at_);
      const Fields f = readRecordHeader();
      const auto op = f.find("op");
      if (op == f.end() || op->second.size() != 1) throw Error(where() + " has no op field");
      const bool consumed = onRecord(op->second[0], f);
      at_ = data_at_ + dlen_;
      if (!consumed) in_.seekg(static_cast<std::streamoff>(at_));
    }
    finish();
  }

 private:
  std::string where() const { return path_ + ": record at byte " + std::to_string(at_); }

  /// Reads the record's header fields and its data length; data_at_ and dlen_ then locate the
  /// data.
  Fields readRecordHeader() {
    std::uint32_t hlen = 0;
    if (size_ - at_ < 4) throw Error(where() + " is cut short");
    in_.read(reinterpret_cast<char*>(&hlen), 4);
    if (hlen > size_ - at_ - 4 || hlen > kMaxHeader) {
      throw Error(where() + " claims a header of " + std::to_string(hlen) +
                  " bytes (file cut short or corrupt; 'rosbag reindex' may repair it)");
    }
    buf_.resize(hlen);
    in_.read(reinterpret_cast<char*>(buf_.data()), static_cast<std::streamsize>(hlen));
    Fields f;
    if (!in_ || !parseFields(buf_.data(), hlen, f))
      throw Error(where() + " has a malformed header");
    data_at_ = at_ + 4 + hlen + 4;
    if (size_ - at_ - 4 - hlen < 4) throw Error(where() + " is cut short");
    in_.read(reinterpret_cast<char*>(&dlen_), 4);
    if (dlen_ > size_ - data_at_) {
      throw Error(where() + " claims " + std::to_string(dlen_) + " bytes of data, the file holds " +
                  std::to_string(size_ - data_at_) +
                  " more (cut short? 'rosbag reindex' may repair it)");
    }
    return f;
  }

  /// Reads the record's data into buf_.
  void readData() {
    buf_.resize(dlen_);
    in_.read(reinterpret_cast<char*>(buf_.data()), static_cast<std::streamsize>(dlen_));
    if (!in_) throw Error(where() + " is cut short");
  }

  /// Checks one record; true when its data was read (the stream is then past it).
  bool onRecord(char op, const Fields& f) {
    switch (op) {
      case 0x03:  // bag header
        index_pos_ = number(f, "index_pos");
        if (index_pos_ > size_) {
          throw Error(where() +
                      ": the index lies beyond the end of the file (cut short? "
                      "'rosbag reindex' may repair it)");
        }
        return false;
      case 0x05:
        return onChunk(f);
      case 0x06:  // chunk info
        chunk_infos_.insert(number(f, "chunk_pos"));
        return false;
      case 0x04:
        return onIndexData(f);
      case 0x07: {  // connection
        readData();
        Fields conn;
        if (!parseFields(buf_.data(), dlen_, conn)) throw Error(where() + ": malformed connection");
        return true;
      }
      case 0x02:  // message
        return false;
      default:
        throw Error(where() + " has an unknown op " + std::to_string(static_cast<int>(op)));
    }
  }

  bool onChunk(const Fields& f) {
    const auto comp = f.find("compression");
    const std::uint64_t unpacked = number(f, "size");
    if (comp == f.end()) throw Error(where() + ": chunk without compression field");
    chunks_.insert(at_);
    if (comp->second == "none") {
      if (unpacked != dlen_) throw Error(where() + ": chunk size disagrees with its data");
      readData();
      in_chunk_ = checkChunk(path_, buf_.data(), dlen_, data_at_);
      chunk_known_ = true;
      return true;
    }
    chunk_known_ = false;  // a compressed chunk's inside is not looked at
    if (comp->second != "bz2" && comp->second != "lz4") {
      throw Error(where() + ": unknown chunk compression '" + comp->second + "'");
    }
    if (unpacked > kMaxChunk || unpacked > 4096ull * dlen_ + (1ull << 24)) {
      throw Error(where() + ": chunk claims " + std::to_string(unpacked) + " unpacked bytes");
    }
    return false;
  }

  /// Index data: where the messages of a connection lie in the last chunk.
  bool onIndexData(const Fields& f) {
    const std::uint64_t count = number(f, "count");
    if (number(f, "ver") != 1 || count * 12 != dlen_)
      throw Error(where() + ": malformed index data");
    if (!chunk_known_) return false;
    readData();
    for (std::uint64_t k = 0; k < count; ++k) {
      std::uint32_t offset = 0;
      std::memcpy(&offset, buf_.data() + 12 * k + 8, 4);
      if (in_chunk_.count(offset) == 0) {
        throw Error(where() + ": index points into the middle of a record");
      }
    }
    return true;
  }

  void finish() const {
    if (index_pos_ == 0) {
      throw Error(path_ +
                  ": the bag has no index (cut short while recording?); run 'rosbag reindex " +
                  path_ + "' first");
    }
    if (records_.count(index_pos_) == 0)
      throw Error(path_ + ": the index position is not a record");
    for (std::uint64_t c : chunk_infos_) {
      if (chunks_.count(c) == 0) throw Error(path_ + ": a chunk info points to no chunk");
    }
  }

  std::string path_;
  std::ifstream in_;
  std::uint64_t size_ = 0;
  std::uint64_t at_ = 0;       ///< the record being read
  std::uint64_t data_at_ = 0;  ///< where its data starts
  std::uint32_t dlen_ = 0;     ///< and how long it is
  std::uint64_t index_pos_ = 0;
  std::set<std::uint64_t> records_, chunks_, chunk_infos_;
  std::set<std::uint64_t> in_chunk_;  ///< record starts in the last uncompressed chunk
  bool chunk_known_ = false;          ///< false after a compressed chunk
  std::vector<std::uint8_t> buf_;
};

}  // namespace

void checkBagStructure(const std::string& path) { BagScan(path).run(); }

namespace {

/// Skips a std_msgs/Header: seq, stamp, frame_id.
bool skipHeader(Cursor& c) {
  std::uint32_t len = 0;
  return c.skip(4 + 8) && c.u32(len) && c.skip(len);
}

}  // namespace

bool pathLengthsFit(const std::uint8_t* data, std::size_t size) {
  Cursor c(data, size);
  std::uint32_t n = 0;
  // Each PoseStamped takes at least a header (16 bytes) and a pose (56 bytes).
  return skipHeader(c) && c.u32(n) && static_cast<std::uint64_t>(n) * 72 <= c.left();
}

bool cloudLengthsFit(const std::uint8_t* data, std::size_t size) {
  Cursor c(data, size);
  std::uint32_t fields = 0, bytes = 0;
  if (!skipHeader(c) || !c.skip(8) || !c.u32(fields)) return false;
  if (static_cast<std::uint64_t>(fields) * 13 > c.left())
    return false;  // name len, offset, type, count
  for (std::uint32_t i = 0; i < fields; ++i) {
    std::uint32_t len = 0;
    if (!c.u32(len) || !c.skip(len) || !c.skip(4 + 1 + 4)) return false;
  }
  return c.skip(1 + 4 + 4) && c.u32(bytes) && bytes <= c.left();
}

}  // namespace flexcloud
