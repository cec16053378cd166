#include "flexcloud/warp/cloud_warp.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <utility>
#include <vector>

#include "flexcloud/uncertainty/point_sigma.h"
#include "parallel.h"
#include "sheet/tet_locator.h"

namespace flexcloud {

Eigen::Vector3d XyzLayout::get(const std::uint8_t* point) const {
  Eigen::Vector3d p;
  for (int a = 0; a < 3; ++a) {
    if (is_double[a]) {
      std::memcpy(&p(a), point + offset[a], sizeof(double));
    } else {
      float v;
      std::memcpy(&v, point + offset[a], sizeof(float));
      p(a) = v;
    }
  }
  return p;
}

void XyzLayout::set(std::uint8_t* point, const Eigen::Vector3d& p) const {
  for (int a = 0; a < 3; ++a) {
    if (is_double[a]) {
      std::memcpy(point + offset[a], &p(a), sizeof(double));
    } else {
      const auto v = static_cast<float>(p(a));
      std::memcpy(point + offset[a], &v, sizeof(float));
    }
  }
}

int resolveThreads(int requested) { return threadCount(requested); }

namespace {

constexpr float kNaNf = std::numeric_limits<float>::quiet_NaN();
constexpr std::size_t kSample = 1 << 18;  // points read to place the fine location cells

/// Reads and writes x, y, z of one layout kind without a branch per axis and point.
struct FloatXyz {
  const XyzLayout& l;
  Eigen::Vector3d get(const std::uint8_t* pt) const {
    float v[3];
    for (int a = 0; a < 3; ++a) std::memcpy(&v[a], pt + l.offset[a], sizeof(float));
    return {v[0], v[1], v[2]};
  }
  void set(std::uint8_t* pt, const Eigen::Vector3d& p) const {
    for (int a = 0; a < 3; ++a) {
      const auto v = static_cast<float>(p(a));
      std::memcpy(pt + l.offset[a], &v, sizeof(float));
    }
  }
};
struct AnyXyz {
  const XyzLayout& l;
  Eigen::Vector3d get(const std::uint8_t* pt) const { return l.get(pt); }
  void set(std::uint8_t* pt, const Eigen::Vector3d& p) const { l.set(pt, p); }
};

/// Spreads the low 21 bits of v to every third bit (for a 3D Morton code).
inline std::uint64_t spreadBits(std::uint64_t v) {
  v &= 0x1FFFFF;
  v = (v | (v << 32)) & 0x1F00000000FFFFull;
  v = (v | (v << 16)) & 0x1F0000FF0000FFull;
  v = (v | (v << 8)) & 0x100F00F00F00F00Full;
  v = (v | (v << 4)) & 0x10C30C30C30C30C3ull;
  v = (v | (v << 2)) & 0x1249249249249249ull;
  return v;
}

/// The Morton code of a point's cell on a 4096^3 grid of cubes over the sheet's box (0.5 m on a
/// 2 km map, 5 m on a 20 km city): points with close codes are close in space. A block's points
/// lie a few metres apart on a city's map, and 0.8 m from a face of their tetrahedron (the
/// median on a simulated drive): 10 m cells (2048^3) left the points within a cell in
/// random order, and 67 % of them in their predecessor's tetrahedron against 73 % here. The height
/// counts as the plan does: the sheet's tetrahedra are stacked (the points beside and above the
/// trajectory), and a code of the plan alone let two points one after the other lie in different
/// tetrahedra far more often (on a simulated drive's shuffled map 39 % of them, against 18 % with
/// the height). 36 bits.
class CellKeys {
 public:
  static constexpr int kBits = 12;

  explicit CellKeys(const Eigen::AlignedBox3d& box)
      : origin_(box.min()),
        inv_cell_(static_cast<double>(1 << kBits) /
                  std::max(1e-3, (box.max() - box.min()).maxCoeff())) {}

  std::uint64_t operator()(const Eigen::Vector3d& p) const {
    return spread(quantize(p.x(), origin_.x())) | (spread(quantize(p.y(), origin_.y())) << 1) |
           (spread(quantize(p.z(), origin_.z())) << 2);
  }

 private:
  /// spreadBits of a 12-bit value from a table of the spread bytes.
  std::uint64_t spread(std::uint32_t v) const {
    return spread_[v & 0xFF] | (std::uint64_t{spread_[v >> 8]} << 24);
  }

  std::uint32_t quantize(double v, double origin) const {
    const double c = std::clamp((v - origin) * inv_cell_, 0.0, (1 << kBits) - 1.0);
    return static_cast<std::uint32_t>(c);
  }

  Eigen::Vector3d origin_;
  double inv_cell_;
  std::array<std::uint32_t, 256> spread_ = [] {
    std::array<std::uint32_t, 256> t{};
    for (std::uint32_t i = 0; i < 256; ++i) t[i] = static_cast<std::uint32_t>(spreadBits(i));
    return t;
  }();
};

/// A block's sort entries: key << kIndexBits | the point's index in its block. Blocks of 2^19
/// points: the more points a block holds, the closer together they lie once sorted, until the
/// block outgrows the caches (10 M shuffled points of a 5 km drive, 2000 control points: blocks
/// of 2^18 38 M/s, 2^19 42 M/s, 2^20 37 M/s; with the sort below, 2^19 45 M/s, 2^20 38-45 M/s,
/// 2^21 39-42 M/s).
constexpr int kIndexBits = 19;
constexpr std::uint64_t kIndexMask = (std::uint64_t{1} << kIndexBits) - 1;

/// Sorts a block's entries (key << kIndexBits | index) by their 36-bit key. One pass by the top
/// 12 bits (their counts made beside the keys) splits the block into coarse cells; each cell's
/// entries, few enough to stay in the core's cache, are then sorted by the lower 24 bits.
class KeySorter {
 public:
  static constexpr int kDigit = CellKeys::kBits;
  static constexpr std::size_t kBuckets = std::size_t{1} << kDigit;

  void clear() { top_.fill(0); }
  void add(std::uint64_t key) { ++top_[key >> (2 * kDigit)]; }  // the top digit of the key

  /// Sorts v; tmp is scratch space.
  void sort(std::vector<std::uint64_t>& v, std::vector<std::uint64_t>& tmp) {
    tmp.resize(v.size());
    std::array<std::uint32_t, kBuckets + 1> start{};
    for (std::size_t d = 0; d < kBuckets; ++d) start[d + 1] = start[d] + top_[d];
    std::array<std::uint32_t, kBuckets> next;
    std::copy(start.begin(), start.end() - 1, next.begin());
    for (const std::uint64_t e : v) tmp[next[digit(e, 2)]++] = e;
    for (std::size_t d = 0; d < kBuckets; ++d) {
      if (start[d + 1] - start[d] > 1)
        sortCell(tmp.data() + start[d], v.data() + start[d], start[d + 1] - start[d]);
    }
    v.swap(tmp);
  }

 private:
  /// Sorts the n entries at a by their lower 24 key bits, using b as scratch; the result is in a.
  void sortCell(std::uint64_t* a, std::uint64_t* b, std::size_t n) {
    if (n < 256) {  // fewer entries than a pass's 4096 counters: a comparison sort
      std::sort(a, a + n);
      return;
    }
    startsOfLowDigits(a, n);
    for (std::size_t i = 0; i < n; ++i) b[low_[0][digit(a[i], 0)]++] = a[i];
    for (std::size_t i = 0; i < n; ++i) a[low_[1][digit(b[i], 1)]++] = b[i];
  }

  static std::size_t digit(std::uint64_t entry, int d) {
    return (entry >> (kIndexBits + d * kDigit)) & (kBuckets - 1);
  }

  /// low_[d][v]: where the first of the n entries at a with value v of digit d goes.
  void startsOfLowDigits(const std::uint64_t* a, std::size_t n) {
    for (auto& c : low_) c.fill(0);
    for (std::size_t i = 0; i < n; ++i) {
      ++low_[0][digit(a[i], 0)];
      ++low_[1][digit(a[i], 1)];
    }
    for (auto& c : low_) {
      std::uint32_t sum = 0;
      for (auto& x : c) sum += std::exchange(x, sum);
    }
  }

  std::array<std::uint32_t, kBuckets> top_{};
  std::array<std::array<std::uint32_t, kBuckets>, 2> low_{};
};

/// Warps points one range at a time, in block-sized steps. Scan-ordered maps are warped in file
/// order, each point trying its predecessor's tetrahedron first, then a walk from there when the
/// points lie close together, else the location grid. When the first guess fails for most points
/// of a block (a map voxel-filtered, merged or shuffled), the following blocks are warped in the
/// order of their points' cells (a Morton code, radix-sorted), so that neighbours in space follow
/// each other again; every point is still written in its own place.
template <typename Xyz>
class RangeWarper {
 public:
  RangeWarper(std::uint8_t* data, std::size_t step, const Xyz& xyz, const RubberSheet& sheet,
              const SigmaSink& sigmas)
      : data_(data),
        sigmas_(sigmas),
        batch_(sigmas.field != nullptr ? std::make_unique<PointSigmaBatch>(sigmas) : nullptr),
        step_(step),
        xyz_(xyz),
        sheet_(sheet),
        tets_(sheet.locatorTets()),
        keys_(sheet.inputBox()) {}

  /// What was counted. Kept here, not in the caller's statistics, which sit beside another
  /// thread's: counting there point by point made two cores fight over one cache line.
  const WarpStats& stats() const { return s_; }

  void run(std::size_t begin, std::size_t end, const CancelToken& cancel) {
    std::size_t block = 0;
    for (std::size_t b = begin; b < end; b += kBlock, ++block) {
      if (cancel.cancelled()) return;
      const std::size_t e = std::min(end, b + kBlock);
      // The first block and every 32nd begin with a few points in file order, to see whether
      // the order holds (or came back); the rest of the block goes the way they say. A map
      // streamed in chunks starts a range per chunk: the probe stays short.
      std::size_t from = b;
      if (block % 32 == 0) {
        from = std::min(e, b + kProbe);
        warpInFileOrder(b, from);
      }
      if (sorted_) {
        warpSorted(from, e);
      } else {
        warpInFileOrder(from, e);
      }
    }
    if (batch_) batch_->flush();
  }

 private:
  static constexpr std::size_t kBlock = std::size_t{1} << kIndexBits;
  static constexpr std::size_t kProbe = 1 << 12;

  /// Points [b, e) in file order; whether most missed their predecessor's tetrahedron decides
  /// the order of the next ones.
  void warpInFileOrder(std::size_t b, std::size_t e) {
    if (b >= e) return;
    hits_ = 0;
    for (std::size_t i = b; i < e; ++i) warpPoint(i);
    sorted_ = hits_ * 2 < e - b;
  }

  void warpSorted(std::size_t b, std::size_t e) {
    order_.resize(e - b);
    sorter_.clear();
    // The virtual machines measured fetched a stream of 24-byte points no earlier than asked
    // (a city's random-order warp 30 -> 38 M points/s with this prefetch).
    constexpr std::size_t kStreamAhead = 32;
    for (std::size_t i = b; i < e; ++i) {
      __builtin_prefetch(data_ + std::min(i + kStreamAhead, e - 1) * step_, 0);
      const Eigen::Vector3d p = xyz_.get(data_ + i * step_);
      const std::uint64_t key = p.allFinite() ? keys_(p) : 0;
      sorter_.add(key);
      order_[i - b] = (key << kIndexBits) | (i - b);
    }
    sorter_.sort(order_, tmp_);
    // The points are read out of file order: fetch a few ahead, or every read waits for memory.
    // Both ends of each: a point may span two cache lines (a 24-byte point one time in four,
    // its coordinates one in eight), and the second line, left to the load, stalled the loop
    // (random order, 2000 control points: 52 -> 63 M points/s).
    constexpr std::size_t kAhead = 64;
    const std::size_t n = order_.size();
    for (std::size_t k = 0; k < n; ++k) {
      if (k + kAhead < n) {
        const std::uint8_t* ahead = data_ + (b + (order_[k + kAhead] & kIndexMask)) * step_;
        __builtin_prefetch(ahead, 1);
        __builtin_prefetch(ahead + step_ - 1, 1);
      }
      warpPoint(b + (order_[k] & kIndexMask));
    }
  }

  void warpPoint(std::size_t i) {
    std::uint8_t* pt = data_ + i * step_;
    const Eigen::Vector3d p = xyz_.get(pt);
    ++s_.points;
    if (!p.allFinite()) {
      ++s_.non_finite;
      sigmas_.write(i, kNaNf, kNaNf);
      return;
    }
    RubberSheet::Location loc{last_, false};
    const int face = last_ >= 0 ? certainExit(tets_[static_cast<std::size_t>(last_)], p) : kInDoubt;
    if (face < 0) {
      ++hits_;
    } else {
      // A walk of a few steps beats the grid's lookups for a point up to tens of metres from
      // the last one (most of a city's points lie in mixed cells, whose candidates and walk
      // cost more). The test above was its first step, unless p lies on a face of the last
      // tetrahedron: then the walk's exact test settles it.
      const bool near = last_ >= 0 && (p - last_point_).squaredNorm() < kNear * kNear;
      loc = near ? walkOn(p, face) : sheet_.locate(p);
      if (loc.outside) {
        ++s_.outside;
      } else {
        hits_ += loc.tet == last_ ? 1 : 0;
        last_ = loc.tet;
        last_point_ = p;
      }
    }
    const Eigen::Vector3d q = RubberSheet::apply(sheet_.affineAt(loc), p);
    xyz_.set(pt, q);
    if (batch_) batch_->add(q, loc.outside ? -1 : loc.tet, i);
  }

  /// The visibility walk from the last tetrahedron, which p lies beyond `face` (or on a face:
  /// kInDoubt), through the records at hand; a point on a face, or a walk longer than a few
  /// steps, goes on in the sheet's own walk, whose exact test settles it.
  RubberSheet::Location walkOn(const Eigen::Vector3d& p, int face) const {
    if (face == kInDoubt) return sheet_.locateFrom(p, last_);
    const int next =
        tets_[static_cast<std::size_t>(last_)].neighbour[static_cast<std::size_t>(face)];
    if (next < 0) return {last_, true};  // beyond the hull
    const WalkEnd end = walkWith(tets_, next, kSteps, [&](int tet) {
      return certainExit(tets_[static_cast<std::size_t>(tet)], p);
    });
    if (end.face == kInDoubt) return sheet_.locateFrom(p, end.tet);
    return {end.tet, end.face == kBeyondHull};
  }

  static constexpr std::size_t kSteps = 16;
  static constexpr double kNear = 50.0;  // m

  std::uint8_t* data_;
  SigmaSink sigmas_;
  std::unique_ptr<PointSigmaBatch> batch_;  // with sigmas asked for; flushed when it goes
  std::size_t step_;
  const Xyz& xyz_;
  const RubberSheet& sheet_;
  const std::vector<LocatorTet>& tets_;
  CellKeys keys_;
  WarpStats s_;
  int last_ = -1;
  Eigen::Vector3d last_point_ = Eigen::Vector3d::Zero();  // the last point located anew
  std::size_t hits_ = 0;
  bool sorted_ = false;
  std::vector<std::uint64_t> order_, tmp_;
  KeySorter sorter_;
};

template <typename Xyz>
void warpRange(std::uint8_t* data, std::size_t begin, std::size_t end, std::size_t step,
               const Xyz& xyz, const RubberSheet& sheet, WarpStats& s, const CancelToken& cancel,
               const SigmaSink& sigmas) {
  RangeWarper<Xyz> warper(data, step, xyz, sheet, sigmas);
  warper.run(begin, end, cancel);
  s = warper.stats();
}

}  // namespace

/// Builds the sheet's location grid from a sample of the points, if not built yet.
static void prepareFor(const std::uint8_t* data, const XyzLayout& layout, const RubberSheet& sheet,
                       int threads) {
  if (sheet.prepared()) return;
  const std::size_t n = layout.points;
  std::vector<Eigen::Vector3d> sample;
  const std::size_t stride = std::max<std::size_t>(1, n / kSample);
  sample.reserve(n / stride + 1);
  for (std::size_t i = 0; i < n; i += stride) {
    sample.push_back(layout.get(data + i * layout.point_step));
  }
  sheet.prepare(threads, &sample);
}

WarpStats warpPoints(std::uint8_t* data, const XyzLayout& layout, const RubberSheet& sheet,
                     int threads, const std::string& name, const CancelToken& cancel,
                     const SigmaSink& sigmas) {
  const std::size_t n = layout.points;
  WarpStats total;
  total.sample = samplePoints(data, layout);
  prepareFor(data, layout, sheet, threads);
  // One contiguous range per thread: each keeps the previous point's tetrahedron as its guess.
  const std::size_t parts = pointRanges(n, threads);
  const bool all_float = !layout.is_double[0] && !layout.is_double[1] && !layout.is_double[2];
  std::vector<WarpStats> part(parts);
  parallelRanges(n, parts, threads, [&](std::size_t k, std::size_t begin, std::size_t end) {
    WarpStats& s = part[k];
    if (all_float) {
      warpRange(data, begin, end, layout.point_step, FloatXyz{layout}, sheet, s, cancel, sigmas);
    } else {
      warpRange(data, begin, end, layout.point_step, AnyXyz{layout}, sheet, s, cancel, sigmas);
    }
  });
  cancel.check(name + ": warp");
  for (const auto& s : part) total.merge(s);
  return total;
}

std::vector<Eigen::Vector3d> samplePoints(const std::uint8_t* data, const XyzLayout& layout) {
  std::vector<Eigen::Vector3d> sample;
  const std::size_t n = layout.points;
  for (std::size_t i = 0, stride = std::max<std::size_t>(1, n / 1000); i < n; i += stride) {
    const Eigen::Vector3d p = layout.get(data + i * layout.point_step);
    if (p.allFinite()) sample.push_back(p);
  }
  return sample;
}

void comparePoints(const std::uint8_t* a, const XyzLayout& la, const std::uint8_t* b,
                   const XyzLayout& lb, std::size_t n,
                   const std::function<Eigen::Vector3d(const Eigen::Vector3d&)>& f,
                   ErrorAccumulator& acc) {
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d p = la.get(a + i * la.point_step);
    const Eigen::Vector3d t = lb.get(b + i * lb.point_step);
    if (!p.allFinite() || !t.allFinite()) continue;
    acc.add((f(p) - t).norm());
  }
}

}  // namespace flexcloud
