#include "flexcloud/io/map_stream.h"

#include <fcntl.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <functional>
#include <future>
#include <optional>

#include "body_copy.h"
#include "flexcloud/io/atomic_file.h"
#include "flexcloud/io/cloud_layout.h"
#include "flexcloud/io/map_precopy.h"
#include "flexcloud/io/pcd_ascii.h"
#include "flexcloud/io/pcd_compressed.h"
#include "flexcloud/io/pcd_io.h"
#include "flexcloud/io/pcd_stream.h"
#include "flexcloud/uncertainty/point_sigma.h"

namespace flexcloud {
namespace {

constexpr std::size_t kSampleBlocks = 1024;  // spread over the file: a map is in scan order
constexpr std::size_t kSampleBlock = 256;

using Clock = std::chrono::steady_clock;

double since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

/// The truth's points chunk by chunk, from a binary file or from one loaded whole.
class TruthSource {
 public:
  TruthSource(const std::string& path, std::size_t points) {
    const PcdHeader h = readPcdHeader(path);
    if (h.points != points) {
      throw Error(path + ": the truth holds " + std::to_string(h.points) + " points, the map " +
                  std::to_string(points));
    }
    if (h.data == PcdHeader::Data::kBinary) {
      reader_.emplace(path);
      layout_ = xyzLayout(pclFields(h), h.point_step, h.points, h.points * h.point_step, path);
    } else {
      whole_ = readPcd(path);
      layout_ = xyzLayout(*whole_, path);
    }
  }
  /// Points [first, first + n) of the truth.
  const std::uint8_t* chunk(std::size_t first, std::size_t n) {
    if (whole_) return whole_->data.data() + first * layout_.point_step;
    buffer_.resize(n * layout_.point_step);
    reader_->readAt(first, n, buffer_.data());
    return buffer_.data();
  }
  const XyzLayout& layout() const { return layout_; }

 private:
  std::optional<PcdChunkReader> reader_;
  std::optional<pcl::PCLPointCloud2> whole_;
  XyzLayout layout_;
  std::vector<std::uint8_t> buffer_;
};

/// The map's points in file order from a binary, ascii or compressed body, and a sample
/// spread over it.
class MapPoints {
 public:
  explicit MapPoints(const std::string& path) {
    switch (readPcdHeader(path).data) {
      case PcdHeader::Data::kBinary:
        binary_.emplace(path);
        break;
      case PcdHeader::Data::kAscii:
        ascii_.emplace(path);
        break;
      case PcdHeader::Data::kBinaryCompressed:
        compressed_.emplace(path);
        break;
    }
  }
  const PcdHeader& header() const {
    return binary_ ? binary_->header() : ascii_ ? ascii_->header() : compressed_->header();
  }
  std::size_t read(std::uint8_t* buf, std::size_t max_points) {
    if (binary_) return binary_->read(buf, max_points);
    return ascii_ ? ascii_->read(buf, max_points) : compressed_->read(buf, max_points);
  }
  /// Up to `blocks` runs of up to `block` points spread over the file, handed to fn.
  void sample(std::size_t blocks, std::size_t block, const PcdPointsFn& fn) const {
    if (ascii_) return ascii_->sample(blocks, block, fn);
    if (compressed_) return compressed_->sample(blocks, block, fn);
    const PcdHeader& h = header();
    block = std::min(block, h.points);
    std::vector<std::uint8_t> buf(block * h.point_step);
    for (std::size_t k = 0; k < blocks && block > 0; ++k) {
      binary_->readAt((h.points - block) * k / std::max<std::size_t>(1, blocks - 1), block,
                      buf.data());
      fn(buf.data(), block);
    }
  }

 private:
  std::optional<PcdChunkReader> binary_;
  std::optional<PcdAsciiReader> ascii_;
  std::optional<PcdCompressedReader> compressed_;
};

/// One map file being warped: the per-chunk work shared by both ways of moving the bytes.
class MapJob {
 public:
  MapJob(const std::string& in, const RubberSheet& sheet, const MapStreamOptions& options,
         MapInfo& info)
      : in_(in),
        reader_(in),
        fields_(pclFields(reader_.header())),
        sheet_(sheet),
        options_(options),
        info_(info) {
    const PcdHeader& h = reader_.header();
    layout_ = xyzLayout(fields_, h.point_step, h.points, h.points * h.point_step, in);
    if (!options.truth.empty()) truth_.emplace(options.truth, h.points);
    if (options.corrections != nullptr) {
      motion_ = mapMotion(
          fields_, options.pose_field, *options.corrections,
          [this](const PointPoseField& f) { return fieldSample(f); }, in);
      info_.pose_field = motion_.rebuild ? motion_.rebuild->field.name : "";
      info_.pose_field_note = motion_.note;
    }
  }

  const PcdHeader& header() const { return reader_.header(); }
  const std::vector<pcl::PCLPointField>& fields() const { return fields_; }
  MapPoints& reader() { return reader_; }
  const std::string& name() const { return in_; }

  /// Builds the location grid from sample blocks spread over the whole file (a map rebuilt
  /// from its points' poses needs none).
  void prepare() {
    if (motion_.rebuild) return;
    const std::size_t step = header().point_step;
    const auto t0 = Clock::now();
    std::vector<Eigen::Vector3d> sample;
    reader_.sample(kSampleBlocks, kSampleBlock, [&](const std::uint8_t* points, std::size_t n) {
      for (std::size_t i = 0; i < n; ++i) sample.push_back(layout_.get(points + i * step));
    });
    info_.read_seconds += since(t0);
    const auto t1 = Clock::now();
    sheet_.prepare(options_.threads, &sample);
    info_.grid_seconds += since(t1);
  }

  /// Points a chunk's buffer holds: a chunk, or the whole map where it is smaller.
  std::size_t bufferPoints() const {
    return std::min(chunk(), std::max<std::size_t>(1, header().points));
  }

  /// The bytes of a point as the warp holds it: the file's row, with point sigmas widened by
  /// room for them (widenPoints), which the warp fills.
  std::size_t rowStep() const {
    return header().point_step + (options_.point_sigma ? kPointSigmaBytes : 0);
  }

  /// Warps points [first, first + n) held at `data` (rows of rowStep()), comparing with the
  /// truth before and after; with point sigmas, the warp writes them into the rows.
  void warp(std::uint8_t* data, std::size_t first, std::size_t n) {
    options_.cancel->check(in_ + ": warp");
    XyzLayout part = layout_;
    part.point_step = rowStep();
    part.points = n;
    const std::uint8_t* t = truth_ ? truth_->chunk(first, n) : nullptr;
    if (t) compare(data, part, t, n, options_.T_enu_map, aligned_);
    const auto t0 = Clock::now();
    SigmaSink sink;
    if (options_.point_sigma) sink = {options_.point_sigma, data + header().point_step, rowStep()};
    const WarpStats s =
        motion_.rebuild
            ? rebuildPoints(data, part, *motion_.rebuild, options_.threads, in_, *options_.cancel,
                            sink)
            : warpPoints(data, part, sheet_, options_.threads, in_, *options_.cancel, sink);
    info_.warp_seconds += since(t0);
    info_.warp.merge(s);
    if (t) compare(data, part, t, n, Eigen::Isometry3d::Identity(), warped_);
  }

  void finish() {
    info_.input = in_;
    if (truth_) {
      info_.has_truth = true;
      info_.truth_aligned = aligned_.stats();
      info_.truth_rubbersheet = warped_.stats();
    }
  }

  MapInfo& info() { return info_; }
  std::size_t chunk() const { return std::max<std::size_t>(1, options_.chunk_points); }

 private:
  void compare(const std::uint8_t* pa, const XyzLayout& la, const std::uint8_t* pb, std::size_t n,
               const Eigen::Isometry3d& f, ErrorAccumulator& acc) const {
    comparePoints(
        pa, la, pb, truth_->layout(), n,
        [&f](const Eigen::Vector3d& p) { return Eigen::Vector3d(f * p); }, acc);
  }

  /// The values of field f of points spread over the file.
  std::vector<double> fieldSample(const PointPoseField& f) const {
    std::vector<double> values;
    const std::size_t step = header().point_step;
    reader_.sample(kSampleBlocks, kSampleBlock, [&](const std::uint8_t* points, std::size_t n) {
      for (std::size_t i = 0; i < n; ++i) values.push_back(f.read(points + i * step));
    });
    return values;
  }

  std::string in_;
  MapPoints reader_;
  MapMotion motion_;
  std::vector<pcl::PCLPointField> fields_;
  XyzLayout layout_;
  const RubberSheet& sheet_;
  const MapStreamOptions& options_;
  MapInfo& info_;
  std::optional<TruthSource> truth_;
  ErrorAccumulator aligned_, warped_;
};

/// Opens the output's temporary file and starts the body's copy into it (startCopy); false
/// (nothing written) where the filesystem cannot reserve space.
bool startBody(MapJob& job, const std::string& in, const AtomicFile& file, const std::string& out,
               const std::string& header, OutputBody& body) {
  body.out.fd = ::open(file.tempPath().c_str(), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (body.out.fd < 0) throw Error(out + ": cannot open for writing: " + std::strerror(errno));
  return startCopy(body, in, job.header(), header, job.chunk(), out);
}

/// Reads the points from `first` on (at most a chunk) into buf; returns how many, 0 at the end.
using ChunkRead = std::function<std::size_t(std::uint8_t* buf, std::size_t first)>;
/// Writes the n warped points of buf, which begin at point `first`.
using ChunkWrite = std::function<void(const std::uint8_t* buf, std::size_t first, std::size_t n)>;

/// Warps a map chunk by chunk through three buffers: chunk i+1 is read and chunk i-1 written
/// while chunk i is warped, so the copies in and out of the buffers keep no core waiting.
void warpChunks(MapJob& job, const ChunkRead& read, const ChunkWrite& write) {
  std::array<std::vector<std::uint8_t>, 3> buffers;
  for (auto& b : buffers) b.resize(job.bufferPoints() * job.rowStep());
  auto readInto = [&](std::size_t slot, std::size_t first) {
    const auto t0 = Clock::now();
    const std::size_t n = read(buffers[slot].data(), first);
    job.info().read_seconds += since(t0);
    return n;
  };
  std::future<std::size_t> next = std::async(std::launch::async, readInto, 0, 0);
  std::future<void> writing;
  std::size_t first = 0;
  for (std::size_t i = 0;; ++i) {
    const std::size_t n = next.get();
    if (n == 0) break;
    std::uint8_t* data = buffers[i % 3].data();
    // Chunk i+1 reuses the buffer of chunk i-2, whose write ended before chunk i-1's began.
    next = std::async(std::launch::async, readInto, (i + 1) % 3, first + n);
    job.warp(data, first, n);
    if (writing.valid()) writing.get();
    writing = std::async(std::launch::async, [&write, &job, data, first, n] {
      const auto t0 = Clock::now();
      write(data, first, n);
      job.info().write_seconds += since(t0);
    });
    first += n;
  }
  if (writing.valid()) writing.get();
}

/// The fast way: reserve the output, copy the body in the kernel (a copier thread runs ahead
/// chunk by chunk; started at the run's start where `precopy` holds this map) and warp the copy
/// in place: each chunk read back, warped and written over. A memory map of the same bytes cost
/// more: every page of a shared file map takes a write fault on its first store (the
/// filesystem's page_mkwrite), 10 % of a city-size run's CPU time. Returns false, having written
/// nothing, where the filesystem cannot reserve space.
bool warpInPlace(MapJob& job, const std::string& in, const std::string& out, MapPrecopy* precopy) {
  const PcdHeader& h = job.header();
  const std::string text = outputHeader(h);
  AtomicFile file(out);
  OutputBody body;
  const bool taken = precopy != nullptr && precopy->takeAs(in, file.tempPath(), body);
  if (!taken && !startBody(job, in, file, out, text, body)) return false;
  job.prepare();  // builds the location grid while the copier runs
  const auto offset = [&](std::size_t first) {
    return static_cast<off_t>(text.size() + first * h.point_step);
  };
  const int fd = body.out.fd;
  warpChunks(
      job,
      [&](std::uint8_t* buf, std::size_t first) -> std::size_t {
        if (first >= h.points) return 0;
        const std::size_t n = std::min(job.chunk(), h.points - first);
        body.copier->waitFor(first + n);
        readAt(fd, buf, n * h.point_step, offset(first), out);
        return n;
      },
      [&](const std::uint8_t* buf, std::size_t first, std::size_t n) {
        writeAt(fd, buf, n * h.point_step, offset(first), out);
      });
  job.info().read_seconds += body.copier->finish();
  const auto t0 = Clock::now();
  if (::close(body.out.release()) != 0)
    throw Error(out + ": write failed: " + std::strerror(errno));
  file.commit();
  job.info().write_seconds += since(t0);
  return true;
}

/// The portable way: read and write the files in order, through buffers (with point sigmas,
/// each chunk's rows widened as read, and written with the sigmas the warp put there).
void warpPipeline(MapJob& job, const std::string& out, bool sigmas) {
  const PcdHeader& h = job.header();
  const auto fields =
      sigmas ? withSigmaFields(job.fields(), h.point_step, job.name()) : job.fields();
  job.prepare();
  PcdChunkWriter writer(out, fields, job.rowStep(), static_cast<std::uint32_t>(h.width),
                        static_cast<std::uint32_t>(h.height));
  std::vector<std::uint8_t> narrow;  // a chunk as the file holds it (one read at a time)
  warpChunks(
      job,
      [&](std::uint8_t* buf, std::size_t) {
        if (!sigmas) return job.reader().read(buf, job.chunk());
        narrow.resize(job.bufferPoints() * h.point_step);
        const std::size_t n = job.reader().read(narrow.data(), job.chunk());
        widenPoints(narrow.data(), h.point_step, n, buf);
        return n;
      },
      [&](const std::uint8_t* buf, std::size_t, std::size_t n) { writer.write(buf, n); });
  const auto t0 = Clock::now();
  writer.commit();
  job.info().write_seconds += since(t0);
}

}  // namespace

void warpPcdFile(const std::string& in, const std::string& out, const RubberSheet& sheet,
                 const MapStreamOptions& options, MapInfo& info) {
  MapJob job(in, sheet, options, info);
  const bool binary = job.header().data == PcdHeader::Data::kBinary;
  const bool sigmas = options.point_sigma != nullptr;
  if (sigmas || !options.in_place || !binary || !warpInPlace(job, in, out, options.precopy)) {
    warpPipeline(job, out, sigmas);
  }
  job.finish();
}

}  // namespace flexcloud
