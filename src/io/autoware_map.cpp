#include "flexcloud/io/autoware_map.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iomanip>
#include <limits>
#include <memory>
#include <sstream>
#include <unordered_map>
#include <vector>

#include "../core/parallel.h"
#include "flexcloud/io/atomic_file.h"
#include "flexcloud/io/cloud_layout.h"
#include "flexcloud/io/pcd_stream.h"
#include "flexcloud/warp/cloud_warp.h"

namespace flexcloud {
namespace {

namespace fs = std::filesystem;

/// A tile's index: floor(x / size), floor(y / size).
using TileKey = std::pair<long long, long long>;
constexpr TileKey kNoTile{std::numeric_limits<long long>::min(), 0};
/// A tile index beyond this (a point some 10^16 m off) has no integer to name its tile.
constexpr double kFarthestTile = 1e15;

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
    layout_ = xyzLayout(fields_, h.point_step, h.points, h.points * h.point_step, map_pcd);
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
        const double tx = std::floor(q.x() / size), ty = std::floor(q.y() / size);
        if (!(std::abs(tx) < kFarthestTile && std::abs(ty) < kFarthestTile)) {
          throw Error(path_ + ": a point at (" + number(q.x()) + ", " + number(q.y()) +
                      ") m lies beyond the reach of the tiles");
        }
        layout_.set(p, q);
        c.tiles[i] = {static_cast<long long>(tx), static_cast<long long>(ty)};
      }
    });
    options_.cancel->check(path_ + ": Autoware tiles");
    return true;
  }

  /// First pass: how many points each tile gets.
  void count(AutowareSummary& s) {
    PcdChunkReader reader(path_);
    Chunk c;
    std::vector<std::uint32_t> id;
    while (next(reader, c)) {
      numberTiles(c, true, id);
      for (const std::uint32_t t : id) {
        if (t == kNone) {
          ++s.non_finite;
        } else {
          ++tiles_[t].count;
        }
      }
    }
  }

  /// Second pass: each chunk sorted by tile, each tile's run written where it belongs in its
  /// file (the counts of the first pass place it).
  void write(const std::string& tile_dir) {
    for (auto& t : tiles_) createTile(tile_dir, t);
    PcdChunkReader reader(path_);
    Chunk c;
    const std::size_t step = layout_.point_step;
    std::vector<std::uint32_t> id;
    std::vector<std::size_t> start(tiles_.size() + 1);
    std::vector<std::uint8_t> sorted;
    while (next(reader, c)) {
      numberTiles(c, false, id);
      std::fill(start.begin(), start.end(), 0);
      for (const std::uint32_t t : id) {
        if (t != kNone) ++start[t + 1];
      }
      for (std::size_t k = 0; k < tiles_.size(); ++k) start[k + 1] += start[k];
      sorted.resize(start.back() * step);
      std::vector<std::size_t> at(start.begin(), start.end() - 1);
      for (std::size_t i = 0; i < c.points; ++i) {
        if (id[i] == kNone) continue;
        std::memcpy(sorted.data() + at[id[i]]++ * step, c.bytes.data() + i * step, step);
      }
      for (std::size_t k = 0; k < tiles_.size(); ++k) {
        const std::size_t n = start[k + 1] - start[k];
        if (n > 0) writeRun(tile_dir, tiles_[k], sorted.data() + start[k] * step, n);
      }
    }
  }

  std::string tileName(const TileKey& k) const {
    return "tile_" + number(static_cast<double>(k.first) * options_.tile_size) + "_" +
           number(static_cast<double>(k.second) * options_.tile_size) + ".pcd";
  }

  std::string metadataYaml() const {
    std::vector<TileKey> keys;
    for (const auto& t : tiles_) keys.push_back(t.key);
    std::sort(keys.begin(), keys.end());
    std::ostringstream s;
    s << "x_resolution: " << number(options_.tile_size) << "\n";
    s << "y_resolution: " << number(options_.tile_size) << "\n";
    for (const auto& key : keys) {
      s << tileName(key) << ": [" << number(static_cast<double>(key.first) * options_.tile_size)
        << ", " << number(static_cast<double>(key.second) * options_.tile_size) << "]\n";
    }
    return s.str();
  }

  std::size_t tiles() const { return tiles_.size(); }
  std::size_t counted() const {
    std::size_t n = 0;
    for (const auto& t : tiles_) n += t.count;
    return n;
  }

 private:
  static constexpr std::uint32_t kNone = 0xFFFFFFFFu;
  static constexpr std::size_t kMaxCells = std::size_t{1} << 22;  // a chunk's grid of tiles

  /// Each point's tile number (kNone where not finite), numbering tiles not seen before when
  /// `add`. One hash lookup per tile a chunk touches, not per point (that had taken 3 s of the
  /// 100 M-point city map's tiles, on one core): the chunk's tiles are cells of a grid over
  /// their bounds first. A chunk spread wider than kMaxCells tiles (a few stray points far
  /// off) is looked up point by point.
  void numberTiles(const Chunk& c, bool add, std::vector<std::uint32_t>& id) {
    id.assign(c.points, kNone);
    TileKey lo{std::numeric_limits<long long>::max(), std::numeric_limits<long long>::max()};
    TileKey hi{std::numeric_limits<long long>::min(), std::numeric_limits<long long>::min()};
    for (const TileKey& t : c.tiles) {
      if (t == kNoTile) continue;
      lo = {std::min(lo.first, t.first), std::min(lo.second, t.second)};
      hi = {std::max(hi.first, t.first), std::max(hi.second, t.second)};
    }
    if (lo.first > hi.first) return;  // no finite point
    const double w = static_cast<double>(hi.first) - static_cast<double>(lo.first) + 1.0;
    const double h = static_cast<double>(hi.second) - static_cast<double>(lo.second) + 1.0;
    const bool grid = w * h <= static_cast<double>(kMaxCells);
    if (grid) cells_.assign(static_cast<std::size_t>(w * h), kNone);
    for (std::size_t i = 0; i < c.points; ++i) {
      const TileKey& t = c.tiles[i];
      if (t == kNoTile) continue;
      if (!grid) {
        id[i] = tileNumber(t, add);
        continue;
      }
      std::uint32_t& cell =
          cells_[static_cast<std::size_t>(t.first - lo.first) * static_cast<std::size_t>(h) +
                 static_cast<std::size_t>(t.second - lo.second)];
      if (cell == kNone) cell = tileNumber(t, add);
      id[i] = cell;
    }
  }

  std::uint32_t tileNumber(const TileKey& t, bool add) {
    if (!add) return ids_.at(t);
    const auto [it, added] = ids_.try_emplace(t, static_cast<std::uint32_t>(tiles_.size()));
    if (added) tiles_.push_back({t});
    return it->second;
  }

  struct TileFile {
    TileKey key;
    std::size_t count = 0;
    std::size_t written = 0;
    std::size_t header = 0;  ///< bytes before the first point
  };
  struct KeyHash {
    std::size_t operator()(const TileKey& k) const {
      return std::hash<long long>()(k.first * 1000003LL ^ k.second);
    }
  };

  void createTile(const std::string& dir, TileFile& t) const {
    const std::string header =
        binaryPcdHeader(fields_, layout_.point_step, static_cast<std::uint32_t>(t.count), 1);
    t.header = header.size();
    writeAt(dir, t, O_WRONLY | O_CREAT | O_TRUNC, header.data(), header.size(), 0);
  }

  void writeRun(const std::string& dir, TileFile& t, const std::uint8_t* data, std::size_t n) {
    const std::size_t step = layout_.point_step;
    writeAt(dir, t, O_WRONLY, data, n * step, t.header + t.written * step);
    t.written += n;
  }

  void writeAt(const std::string& dir, const TileFile& t, int flags, const void* data,
               std::size_t size, std::size_t offset) const {
    const std::string path = (fs::path(dir) / tileName(t.key)).string();
    const int fd = ::open(path.c_str(), flags | O_CLOEXEC, 0644);
    bool ok = fd >= 0;
    const auto* p = static_cast<const std::uint8_t*>(data);
    while (ok && size > 0) {
      const ssize_t w = ::pwrite(fd, p, size, static_cast<off_t>(offset));
      ok = w > 0;
      if (ok) {
        p += w;
        size -= static_cast<std::size_t>(w);
        offset += static_cast<std::size_t>(w);
      }
    }
    if (fd >= 0 && ::close(fd) != 0) ok = false;
    if (!ok) throw Error(path + ": cannot write the tile: " + std::strerror(errno));
  }

  std::string path_;
  AutowareOptions options_;
  MapProjection projection_;
  PcdChunkReader reader_;
  std::vector<pcl::PCLPointField> fields_;
  XyzLayout layout_;
  std::unordered_map<TileKey, std::uint32_t, KeyHash> ids_;
  std::vector<TileFile> tiles_;
  std::vector<std::uint32_t> cells_;  ///< a chunk's tile numbers on the grid over its tiles
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
  // Autoware reads no origin altitude (it takes 0): the tiles' z is the ellipsoidal height.
  const Datum& d = projection.datum();
  s << "map_origin:\n  latitude: " << d.lat << "\n  longitude: " << d.lon
    << "\n  altitude: 0.0  # the tiles' z is the ellipsoidal height (WGS84)\n";
  return s.str();
}

AutowareSummary writeAutowareMap(const std::string& map_pcd, const std::string& dir,
                                 const Datum& datum, const AutowareOptions& options) {
  if (!(options.tile_size > 0.0) || !std::isfinite(options.tile_size)) {
    throw Error("tile_size " + number(options.tile_size) + " m: must be a positive length");
  }
  if (options.tile_size != std::round(options.tile_size)) {
    throw Error("tile_size " + number(options.tile_size) +
                " m: Autoware reads the tiles' corners as integers; give whole metres");
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
