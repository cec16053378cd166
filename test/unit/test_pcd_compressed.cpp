// The streamed LZF decoder and binary_compressed reader against PCL's own LZF codec and reader.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <pcl/io/lzf.h>
#include <pcl/io/pcd_io.h>
#include <unistd.h>

#include <cstring>
#include <optional>
#include <random>
#include <unordered_set>

#include "flexcloud/io/cloud_layout.h"
#include "flexcloud/io/pcd_compressed.h"
#include "flexcloud/io/pcd_io.h"
#include "flexcloud/types.h"
#include "test_util.h"

namespace flexcloud {
namespace {

/// Bytes that compress: runs, repeats at every distance up to LZF's 8 KiB, and noise.
std::vector<std::uint8_t> mixedBytes(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<std::uint8_t> v;
  while (v.size() < n) {
    const unsigned kind = rng() % 3;
    const std::size_t len = 1 + rng() % 600;
    for (std::size_t i = 0; i < len && v.size() < n; ++i) {
      if (kind == 0 || v.size() < 9000) {
        v.push_back(static_cast<std::uint8_t>(rng()));
      } else if (kind == 1) {
        v.push_back(v[v.size() - 1 - rng() % 3]);  // runs: references that overlap
      } else {
        v.push_back(v[v.size() - 8192 + (rng() % 4096)]);  // far references
      }
    }
  }
  return v;
}

/// The LZF block of `raw` (PCL's compressor) in a file; returns its path and packed size.
std::pair<std::string, std::size_t> packed(const std::vector<std::uint8_t>& raw,
                                           const std::string& name) {
  std::vector<std::uint8_t> out(raw.size() * 2 + 64);
  const unsigned n = pcl::lzfCompress(raw.data(), static_cast<unsigned>(raw.size()), out.data(),
                                      static_cast<unsigned>(out.size()));
  EXPECT_GT(n, 0u);
  return {test::writeTempFile(name, std::string(out.begin(), out.begin() + n)), n};
}

TEST(LzfDecoder, MatchesPclsCodecInPiecesOfAnySizeAndFromCheckpoints) {
  const std::vector<std::uint8_t> raw = mixedBytes(300000, 5);
  const auto block = packed(raw, "lzf_mixed.bin");
  const std::string& path = block.first;
  const std::size_t size = block.second;
  const int fd = ::open(path.c_str(), O_RDONLY);
  ASSERT_GE(fd, 0);
  LzfDecoder d(fd, 0, size, raw.size(), path);
  std::vector<std::uint8_t> got(raw.size());
  std::mt19937 rng(1);
  std::size_t at = 0;
  std::optional<LzfDecoder> checkpoint;
  std::size_t checkpoint_at = 0;
  while (at < raw.size()) {
    const std::size_t k = std::min<std::size_t>(raw.size() - at, 1 + rng() % 20000);
    if (!checkpoint && at > 100000) checkpoint = d, checkpoint_at = at;
    d.read(k % 7 == 0 ? nullptr : got.data() + at, k);  // some pieces passed over
    if (k % 7 == 0) std::memcpy(got.data() + at, raw.data() + at, k);
    at += k;
  }
  EXPECT_TRUE(d.done());
  EXPECT_EQ(got, raw);
  ASSERT_TRUE(checkpoint);
  std::vector<std::uint8_t> rest(raw.size() - checkpoint_at);
  checkpoint->read(rest.data(), rest.size());
  EXPECT_TRUE(std::equal(rest.begin(), rest.end(), raw.begin() + checkpoint_at));
  ::close(fd);
}

TEST(LzfDecoder, CorruptBlocksAreErrorsNotCrashes) {
  const std::vector<std::uint8_t> raw = mixedBytes(50000, 7);
  const auto block = packed(raw, "lzf_corrupt.bin");
  const std::string path = block.first;  // (a lambda below takes these: no structured binding)
  const std::size_t size = block.second;
  const int fd = ::open(path.c_str(), O_RDONLY);
  ASSERT_GE(fd, 0);
  const auto errorOf = [&](std::uint64_t in, std::uint64_t out) {
    return test::errorOf([&] {
      LzfDecoder d(fd, 0, in, out, path);
      std::vector<std::uint8_t> buf(out);
      d.read(buf.data(), out);
      if (!d.done()) throw Error(path + ": the compressed body is corrupt");
    });
  };
  EXPECT_NE(errorOf(size - 3, raw.size()).find("is corrupt"), std::string::npos);   // cut
  EXPECT_NE(errorOf(size, raw.size() - 10).find("is corrupt"), std::string::npos);  // too long
  EXPECT_NE(errorOf(size, raw.size() + 10).find("is corrupt"), std::string::npos);  // too short
  ::close(fd);
  // A reference before the first byte: "\x20\x05" asks for 3 bytes from 6 back.
  const std::string bad = test::writeTempFile("lzf_before.bin", std::string("\x00"
                                                                            "A\x20\x05",
                                                                            4));
  const int fd2 = ::open(bad.c_str(), O_RDONLY);
  const std::string e = test::errorOf([&] {
    LzfDecoder d(fd2, 0, 4, 4, bad);
    std::uint8_t buf[4];
    d.read(buf, 4);
  });
  EXPECT_NE(e.find("lzf_before.bin: the compressed body is corrupt"), std::string::npos) << e;
  ::close(fd2);
}

TEST(PcdCompressedReader, ChunksEqualPclsWholeRead) {
  pcl::PCLPointCloud2 cloud;
  const char* names[] = {"x", "y", "z", "intensity", "ring"};
  const std::uint8_t types[] = {pcl::PCLPointField::FLOAT32, pcl::PCLPointField::FLOAT32,
                                pcl::PCLPointField::FLOAT64, pcl::PCLPointField::FLOAT32,
                                pcl::PCLPointField::UINT16};
  const std::uint32_t offsets[] = {0, 4, 8, 16, 20};
  for (int i = 0; i < 5; ++i) {
    cloud.fields.push_back(pointField(names[i], offsets[i], types[i]));
  }
  cloud.point_step = 22;
  cloud.width = 123457;
  cloud.height = 1;
  cloud.row_step = cloud.point_step * cloud.width;
  const std::vector<std::uint8_t> bytes = mixedBytes(cloud.row_step, 3);
  cloud.data.assign(bytes.begin(), bytes.end());
  const std::string path = ::testing::TempDir() + "compressed_chunks.pcd";
  ASSERT_EQ(pcl::PCDWriter().writeBinaryCompressed(path, cloud), 0);
  pcl::PCLPointCloud2 reference;
  ASSERT_EQ(pcl::PCDReader().read(path, reference), 0);

  PcdCompressedReader reader(path);
  ASSERT_EQ(reader.header().point_step, 22u);
  std::unordered_set<std::string> xyz;  // the bytes of x, y and z of every point
  for (std::size_t i = 0; i < cloud.width; ++i) {
    xyz.emplace(reinterpret_cast<const char*>(reference.data.data()) + i * 22, 16);
  }
  std::size_t sampled = 0;
  reader.sample(16, 100, [&](const std::uint8_t* p, std::size_t n) {
    for (std::size_t i = 0; i < n; ++i) {
      sampled += xyz.count(std::string(reinterpret_cast<const char*>(p) + i * 22, 16));
    }
  });
  EXPECT_EQ(sampled, 1600u);
  std::vector<std::uint8_t> got(reference.data.size());
  std::size_t at = 0;
  for (std::size_t chunk = 1; at < cloud.width; chunk = chunk * 3 + 1) {
    at += reader.read(got.data() + at * 22, chunk);
  }
  EXPECT_EQ(reader.read(got.data(), 10), 0u);
  EXPECT_EQ(got, reference.data);
  EXPECT_EQ(readPcd(path).data, reference.data);  // and so does the whole read
  pcl::PCLPointCloud2 pcl_read;                   // and PCL's own reader of the file
  ASSERT_EQ(pcl::io::loadPCDFile(path, pcl_read), 0);
  EXPECT_EQ(pcl_read.data, reference.data);
}

}  // namespace
}  // namespace flexcloud
