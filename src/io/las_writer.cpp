#include "flexcloud/io/las_writer.h"

#include <proj.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <limits>
#include <memory>
#include <optional>
#include <vector>

#include "../core/parallel.h"
#include "flexcloud/geo/projection.h"
#include "flexcloud/io/pcd_stream.h"

namespace flexcloud {
namespace {

constexpr double kScale = 0.001;          // m per LAS coordinate unit
constexpr std::size_t kHeaderSize = 375;  // LAS 1.4 public header block
constexpr std::size_t kVlrHeaderSize = 54;
constexpr std::size_t kExtraBytesDescriptor = 192;
constexpr std::size_t kChunk = 1 << 20;

/// A little-endian byte writer into a buffer at fixed offsets.
class Bytes {
 public:
  explicit Bytes(std::size_t n) : b_(n, 0) {}
  template <typename T>
  void put(std::size_t at, T v) {
    std::memcpy(&b_[at], &v, sizeof(T));
  }
  void text(std::size_t at, const std::string& s, std::size_t width) {
    std::memcpy(&b_[at], s.data(), std::min(s.size(), width));
  }
  const std::vector<std::uint8_t>& data() const { return b_; }
  std::vector<std::uint8_t>& data() { return b_; }

 private:
  std::vector<std::uint8_t> b_;
};

/// One PCD field element, read as a number.
struct Element {
  std::string name;
  std::size_t offset = 0;
  std::size_t size = 4;
  char type = 'F';

  double read(const std::uint8_t* p) const {
    p += offset;
    switch (type) {
      case 'F':
        return size == 8 ? load<double>(p) : load<float>(p);
      case 'U':
        return size == 1   ? load<std::uint8_t>(p)
               : size == 2 ? load<std::uint16_t>(p)
               : size == 4 ? load<std::uint32_t>(p)
                           : static_cast<double>(load<std::uint64_t>(p));
      default:
        return size == 1   ? load<std::int8_t>(p)
               : size == 2 ? load<std::int16_t>(p)
               : size == 4 ? load<std::int32_t>(p)
                           : static_cast<double>(load<std::int64_t>(p));
    }
  }
  /// LAS extra bytes data type code of the element (1..10).
  std::uint8_t lasType() const {
    const int k = size == 1 ? 0 : size == 2 ? 1 : size == 4 ? 2 : 3;
    if (type == 'F') return size == 8 ? 10 : 9;
    return static_cast<std::uint8_t>(1 + 2 * k + (type == 'I' ? 1 : 0));
  }
  template <typename T>
  static T load(const std::uint8_t* p) {
    T v;
    std::memcpy(&v, p, sizeof(T));
    return v;
  }
};

/// Where the parts of a LAS point come from in a PCD point.
struct PointMap {
  std::array<Element, 3> xyz;
  std::optional<Element> intensity;
  std::optional<Element> rgb;  ///< packed 0x00RRGGBB (float bits or uint32)
  std::vector<Element> extra;  ///< copied byte for byte after the standard part
  std::size_t standard = 30;   ///< bytes of the standard part: 30 (format 6) or 36 (7)
  std::size_t record = 30;

  static PointMap of(const PcdHeader& h, const std::string& name) {
    PointMap m;
    bool found[3] = {false, false, false};
    for (const PcdField& f : h.fields) {
      if (f.name == "_") continue;
      for (std::size_t i = 0; i < f.count; ++i) {
        Element e{f.count > 1 ? f.name + "_" + std::to_string(i) : f.name, f.offset + i * f.size,
                  f.size, f.type};
        const int axis = f.name == "x" ? 0 : f.name == "y" ? 1 : f.name == "z" ? 2 : -1;
        if (axis >= 0 && f.count == 1) {
          m.xyz[axis] = e;
          found[axis] = true;
        } else if (f.name == "intensity" && f.count == 1) {
          m.intensity = e;
        } else if ((f.name == "rgb" || f.name == "rgba") && f.count == 1 && f.size == 4) {
          m.rgb = e;
        } else {
          e.name = e.name.substr(0, 32);
          m.extra.push_back(e);
        }
      }
    }
    if (!found[0] || !found[1] || !found[2]) throw Error(name + ": the map has no x, y, z");
    m.standard = m.rgb ? 36 : 30;
    m.record = m.standard;
    for (const auto& e : m.extra) m.record += e.size;
    return m;
  }
};

std::uint16_t toU16(double v) {
  if (!std::isfinite(v)) return 0;
  return static_cast<std::uint16_t>(std::clamp(std::round(v), 0.0, 65535.0));
}

/// The LAS writer of one map.
class LasFile {
 public:
  LasFile(const std::string& map_pcd, const std::string& path, const Datum& datum)
      : map_(map_pcd), path_(path), projection_(datum, ProjectorType::kLocalCartesianUtm) {
    reader_ = std::make_unique<PcdChunkReader>(map_pcd);
    points_ = PointMap::of(reader_->header(), map_pcd);
    const Eigen::Vector3d o = projection_.utmFromEnu(Eigen::Vector3d::Zero());
    offset_ = {std::round(o.x() / 1000.0) * 1000.0, std::round(o.y() / 1000.0) * 1000.0,
               std::round(o.z())};
    wkt_ = wktOfEpsg(projection_.zone().epsg());
    file_.reset(std::fopen(path.c_str(), "wb"));
    if (!file_) throw Error(path + ": cannot create the LAS file");
  }

  LasSummary write(int threads, const CancelToken& cancel) {
    const std::vector<std::uint8_t> vlrs = vlrBytes();
    const std::size_t data_offset = kHeaderSize + vlrs.size();
    put(std::vector<std::uint8_t>(kHeaderSize, 0));  // completed at the end
    put(vlrs);
    const std::size_t step = reader_->header().point_step;
    std::vector<std::uint8_t> in(kChunk * step);
    std::vector<std::uint8_t> out(kChunk * points_.record);
    std::vector<std::uint8_t> ok(kChunk);
    LasSummary s;
    for (std::size_t n; (n = reader_->read(in.data(), kChunk)) > 0;) {
      parallelRanges(n, 64, threads, [&](std::size_t, std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i) {
          ok[i] = convert(in.data() + i * step, out.data() + i * points_.record);
        }
      });
      std::size_t kept = 0;
      for (std::size_t i = 0; i < n; ++i) {
        if (!ok[i]) continue;
        if (kept != i) {
          std::memmove(out.data() + kept * points_.record, out.data() + i * points_.record,
                       points_.record);
        }
        extend(out.data() + kept * points_.record);
        ++kept;
      }
      s.non_finite += n - kept;
      s.points += kept;
      put(out.data(), kept * points_.record);
      cancel.check(path_ + ": LAS");
    }
    if (std::fseek(file_.get(), 0, SEEK_SET) != 0) throw Error(path_ + ": cannot seek");
    put(header(s.points, data_offset).data());
    if (std::fflush(file_.get()) != 0) throw Error(path_ + ": cannot write the LAS file");
    s.epsg = projection_.zone().epsg();
    s.point_format = points_.rgb ? 7 : 6;
    s.extra_fields = points_.extra.size();
    return s;
  }

 private:
  /// One PCD point as a LAS record; false for a non-finite point.
  bool convert(const std::uint8_t* p, std::uint8_t* r) const {
    const Eigen::Vector3d enu(points_.xyz[0].read(p), points_.xyz[1].read(p),
                              points_.xyz[2].read(p));
    if (!enu.allFinite()) return false;
    const Eigen::Vector3d utm = projection_.utmFromEnu(enu);
    std::memset(r, 0, points_.standard);
    for (int a = 0; a < 3; ++a) {
      const double q = std::round((utm[a] - offset_[a]) / kScale);
      if (!(std::abs(q) < 2147483647.0)) {
        throw Error(map_ + ": a point lies more than 2147 km from the LAS offset");
      }
      const std::int32_t v = static_cast<std::int32_t>(q);
      std::memcpy(r + 4 * a, &v, 4);
    }
    const std::uint16_t intensity = points_.intensity ? toU16(points_.intensity->read(p)) : 0;
    std::memcpy(r + 12, &intensity, 2);
    r[14] = 0x11;  // return 1 of 1
    if (points_.rgb) {
      std::uint32_t packed = 0;
      std::memcpy(&packed, p + points_.rgb->offset, 4);
      const std::uint16_t c[3] = {static_cast<std::uint16_t>(((packed >> 16) & 0xff) * 257),
                                  static_cast<std::uint16_t>(((packed >> 8) & 0xff) * 257),
                                  static_cast<std::uint16_t>((packed & 0xff) * 257)};
      std::memcpy(r + 30, c, 6);
    }
    std::size_t at = points_.standard;
    for (const auto& e : points_.extra) {
      std::memcpy(r + at, p + e.offset, e.size);
      at += e.size;
    }
    return true;
  }

  void extend(const std::uint8_t* r) {
    for (int a = 0; a < 3; ++a) {
      std::int32_t v;
      std::memcpy(&v, r + 4 * a, 4);
      min_[a] = std::min(min_[a], v);
      max_[a] = std::max(max_[a], v);
    }
  }

  std::vector<std::uint8_t> vlrBytes() const {
    std::vector<std::uint8_t> all =
        vlr("LASF_Projection", 2112, "OGC WKT coordinate system",
            std::vector<std::uint8_t>(wkt_.c_str(), wkt_.c_str() + wkt_.size() + 1));
    if (!points_.extra.empty()) {
      Bytes d(kExtraBytesDescriptor * points_.extra.size());
      for (std::size_t i = 0; i < points_.extra.size(); ++i) {
        const std::size_t at = i * kExtraBytesDescriptor;
        d.put<std::uint8_t>(at + 2, points_.extra[i].lasType());
        d.text(at + 4, points_.extra[i].name, 32);
        d.text(at + 160, "PCD field " + points_.extra[i].name, 32);
      }
      const auto e = vlr("LASF_Spec", 4, "PCD fields", d.data());
      all.insert(all.end(), e.begin(), e.end());
    }
    return all;
  }

  static std::vector<std::uint8_t> vlr(const std::string& user, std::uint16_t id,
                                       const std::string& description,
                                       const std::vector<std::uint8_t>& payload) {
    if (payload.size() > 65535) throw Error("LAS: a VLR payload exceeds 65535 bytes");
    Bytes h(kVlrHeaderSize);
    h.text(2, user, 16);
    h.put<std::uint16_t>(18, id);
    h.put<std::uint16_t>(20, static_cast<std::uint16_t>(payload.size()));
    h.text(22, description, 32);
    std::vector<std::uint8_t> out = h.data();
    out.insert(out.end(), payload.begin(), payload.end());
    return out;
  }

  Bytes header(std::uint64_t points, std::size_t data_offset) const {
    Bytes h(kHeaderSize);
    h.text(0, "LASF", 4);
    h.put<std::uint16_t>(6, 16);  // global encoding: the CRS is WKT
    h.put<std::uint8_t>(24, 1);
    h.put<std::uint8_t>(25, 4);
    h.text(26, "flexcloud", 32);
    h.text(58, "flexcloud georeference", 32);
    const std::time_t now = std::time(nullptr);
    std::tm utc{};
    gmtime_r(&now, &utc);
    h.put<std::uint16_t>(90, static_cast<std::uint16_t>(utc.tm_yday + 1));
    h.put<std::uint16_t>(92, static_cast<std::uint16_t>(utc.tm_year + 1900));
    h.put<std::uint16_t>(94, static_cast<std::uint16_t>(kHeaderSize));
    h.put<std::uint32_t>(96, static_cast<std::uint32_t>(data_offset));
    h.put<std::uint32_t>(100, points_.extra.empty() ? 1u : 2u);
    h.put<std::uint8_t>(104, points_.rgb ? 7 : 6);
    h.put<std::uint16_t>(105, static_cast<std::uint16_t>(points_.record));
    for (int a = 0; a < 3; ++a) {
      h.put<double>(131 + 8 * a, kScale);
      h.put<double>(155 + 8 * a, offset_[a]);
      const bool any = points > 0;
      h.put<double>(179 + 16 * a, any ? offset_[a] + max_[a] * kScale : 0.0);
      h.put<double>(187 + 16 * a, any ? offset_[a] + min_[a] * kScale : 0.0);
    }
    h.put<std::uint64_t>(247, points);
    h.put<std::uint64_t>(255, points);  // all are first returns
    return h;
  }

  void put(const std::vector<std::uint8_t>& b) { put(b.data(), b.size()); }
  void put(const std::uint8_t* data, std::size_t n) {
    if (n > 0 && std::fwrite(data, 1, n, file_.get()) != n) {
      throw Error(path_ + ": cannot write the LAS file");
    }
  }

  struct Closer {
    void operator()(FILE* f) const { std::fclose(f); }
  };

  std::string map_;
  std::string path_;
  MapProjection projection_;
  std::unique_ptr<PcdChunkReader> reader_;
  PointMap points_;
  std::array<double, 3> offset_{};
  std::string wkt_;
  std::unique_ptr<FILE, Closer> file_;
  std::array<std::int32_t, 3> min_{std::numeric_limits<std::int32_t>::max(),
                                   std::numeric_limits<std::int32_t>::max(),
                                   std::numeric_limits<std::int32_t>::max()};
  std::array<std::int32_t, 3> max_{std::numeric_limits<std::int32_t>::min(),
                                   std::numeric_limits<std::int32_t>::min(),
                                   std::numeric_limits<std::int32_t>::min()};
};

}  // namespace

std::string wktOfEpsg(int epsg) {
  std::unique_ptr<PJ_CONTEXT, PJ_CONTEXT* (*)(PJ_CONTEXT*)> ctx(proj_context_create(),
                                                                &proj_context_destroy);
  const std::string code = std::to_string(epsg);
  std::unique_ptr<PJ, PJ* (*)(PJ*)> crs(
      proj_create_from_database(ctx.get(), "EPSG", code.c_str(), PJ_CATEGORY_CRS, 0, nullptr),
      &proj_destroy);
  const char* wkt = crs ? proj_as_wkt(ctx.get(), crs.get(), PJ_WKT1_GDAL, nullptr) : nullptr;
  if (wkt == nullptr) throw Error("EPSG:" + code + ": PROJ's database does not know this CRS");
  return wkt;
}

LasSummary writeLas(const std::string& map_pcd, const std::string& las_path, const Datum& datum,
                    int threads, const CancelToken& cancel) {
  utmZoneOf(datum);  // a clear message beyond UTM's reach, before anything is written
  LasFile f(map_pcd, las_path, datum);
  return f.write(threads, cancel);
}

}  // namespace flexcloud
