#include "flexcloud/io/autoware_map.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iomanip>
#include <limits>
#include <map>
#include <memory>
#include <sstream>
#include <vector>

#include "../core/parallel.h"
#include "flexcloud/cloud_warp.h"
#include "flexcloud/io/atomic_file.h"
#include "flexcloud/io/pcd_stream.h"

namespace flexcloud {
namespace {

namespace fs = std::filesystem;

/// A tile's index: floor(x / size), floor(y / size).
using TileKey = std::pair<long long, long long>;
constexpr TileKey kNoTile{std::numeric_limits<long long>::min(), 0};

std::string number(double v) {
  std::ostringstream s;
  s << std::setprecision(15) << v;
  return s.str();
}

/// One chunk of the map, reprojected: the points' bytes with x, y, z in the projector's frame,
/// and each point's tile (kNoTile for a non-finite point).
struct Chunk {
  std::vector<std::uint8_t> bytes;
  std::vector<TileKey> tiles;
  std::size_t points = 0;
};

class Tiler {
 public:
  Tiler(const std::string& map_pcd, const Datum& datum, const AutowareOptions& o)
      : path_(map_pcd), options_(o), projection_(datum, o.projector), reader_(map_pcd) {
    const PcdHeader& h = reader_.header();
    fields_ = pclFields(h);
    layout_ = XyzLayout::of(fields_, h.point_step, h.points, h.points * h.point_step, map_pcd);
  }

  const MapProjection& projection() const { return projection_; }

  /// Reads and reprojects the next chunk; false at the end of the map.
  bool next(PcdChunkReader& reader, Chunk& c) {
    const std::size_t step = layout_.point_step;
    c.bytes.resize(options_.buffer_points * step);
    c.points = reader.read(c.bytes.data(), options_.buffer_points);
    if (c.points == 0) return false;
    c.tiles.assign(c.points, kNoTile);
    const double size = options_.tile_size;
    parallelRanges(c.points, 64, options_.threads, [&](std::size_t, std::size_t b, std::size_t e) {
      for (std::size_t i = b; i < e; ++i) {
        std::uint8_t* p = c.bytes.data() + i * step;
        const Eigen::Vector3d enu = layout_.get(p);
        if (!enu.allFinite()) continue;
        const Eigen::Vector3d q = projection_.fromEnu(enu);
        layout_.set(p, q);
        c.tiles[i] = {static_cast<long long>(std::floor(q.x() / size)),
                      static_cast<long long>(std::floor(q.y() / size))};
      }
    });
    options_.cancel->check(path_ + ": Autoware tiles");
    return true;
  }

  /// First pass: how many points each tile gets.
  void count(AutowareSummary& s) {
    PcdChunkReader reader(path_);
    Chunk c;
    while (next(reader, c)) {
      for (const TileKey& t : c.tiles) {
        if (t == kNoTile) {
          ++s.non_finite;
        } else {
          ++counts_[t];
        }
      }
    }
  }

  /// Second pass: appends every point to its tile's file.
  void write(const std::string& tile_dir) {
    for (const auto& [key, n] : counts_) {
      openTile(tile_dir, key, n);
    }
    PcdChunkReader reader(path_);
    Chunk c;
    const std::size_t step = layout_.point_step;
    std::map<TileKey, std::vector<std::uint8_t>> buffers;
    while (next(reader, c)) {
      for (std::size_t i = 0; i < c.points; ++i) {
        if (c.tiles[i] == kNoTile) continue;
        auto& b = buffers[c.tiles[i]];
        b.insert(b.end(), c.bytes.data() + i * step, c.bytes.data() + (i + 1) * step);
      }
      for (auto& [key, b] : buffers) append(tile_dir, key, b);
      buffers.clear();
    }
  }

  std::string tileName(const TileKey& k) const {
    return "tile_" + number(static_cast<double>(k.first) * options_.tile_size) + "_" +
           number(static_cast<double>(k.second) * options_.tile_size) + ".pcd";
  }

  std::string metadataYaml() const {
    std::ostringstream s;
    s << "x_resolution: " << number(options_.tile_size) << "\n";
    s << "y_resolution: " << number(options_.tile_size) << "\n";
    for (const auto& [key, n] : counts_) {
      s << tileName(key) << ": [" << number(static_cast<double>(key.first) * options_.tile_size)
        << ", " << number(static_cast<double>(key.second) * options_.tile_size) << "]\n";
    }
    return s.str();
  }

  std::size_t tiles() const { return counts_.size(); }
  std::size_t counted() const {
    std::size_t n = 0;
    for (const auto& [key, c] : counts_) n += c;
    return n;
  }

 private:
  void openTile(const std::string& dir, const TileKey& key, std::size_t n) {
    const std::string header =
        binaryPcdHeader(fields_, layout_.point_step, static_cast<std::uint32_t>(n), 1);
    writeBytes(dir, key, "wb", header.data(), header.size());
  }

  void append(const std::string& dir, const TileKey& key, const std::vector<std::uint8_t>& b) {
    writeBytes(dir, key, "ab", b.data(), b.size());
  }

  void writeBytes(const std::string& dir, const TileKey& key, const char* mode, const void* data,
                  std::size_t size) const {
    const std::string path = (fs::path(dir) / tileName(key)).string();
    std::unique_ptr<FILE, int (*)(FILE*)> f(std::fopen(path.c_str(), mode), &std::fclose);
    if (!f || std::fwrite(data, 1, size, f.get()) != size || std::fflush(f.get()) != 0) {
      throw Error(path + ": cannot write the tile");
    }
  }

  std::string path_;
  AutowareOptions options_;
  MapProjection projection_;
  PcdChunkReader reader_;
  std::vector<pcl::PCLPointField> fields_;
  XyzLayout layout_;
  std::map<TileKey, std::size_t> counts_;
};

}  // namespace

std::string projectorInfoYaml(const MapProjection& projection) {
  std::ostringstream s;
  s << std::setprecision(12);
  s << "projector_type: " << autowareProjectorType(projection.type()) << "\n";
  s << "vertical_datum: WGS84\n";
  if (projection.type() == ProjectorType::kMgrs) {
    s << "mgrs_grid: " << projection.mgrsGrid() << "\n";
  }
  const Datum& d = projection.datum();
  s << "map_origin:\n  latitude: " << d.lat << "\n  longitude: " << d.lon
    << "\n  altitude: " << d.alt << "\n";
  return s.str();
}

AutowareSummary writeAutowareMap(const std::string& map_pcd, const std::string& dir,
                                 const Datum& datum, const AutowareOptions& options) {
  if (!(options.tile_size > 0.0) || !std::isfinite(options.tile_size)) {
    throw Error("tile_size " + number(options.tile_size) + " m: must be a positive length");
  }
  Tiler tiler(map_pcd, datum, options);
  AutowareSummary s;
  tiler.count(s);
  const std::string tile_dir = (fs::path(dir) / "pointcloud_map").string();
  makeDirectories(tile_dir);
  tiler.write(tile_dir);
  writeTextFile((fs::path(dir) / "pointcloud_map_metadata.yaml").string(), tiler.metadataYaml());
  writeTextFile((fs::path(dir) / "map_projector_info.yaml").string(),
                projectorInfoYaml(tiler.projection()));
  s.tiles = tiler.tiles();
  s.points = tiler.counted();
  s.mgrs_grid = tiler.projection().mgrsGrid();
  return s;
}

}  // namespace flexcloud
