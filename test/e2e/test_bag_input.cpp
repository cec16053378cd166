// The bag input path with bags written here through rosbag: topic choice, the three pose types,
// and corrupt messages.
#include <gtest/gtest.h>
#include <ros/time.h>
#include <rosbag/bag.h>

#include <filesystem>
#include <fstream>

#include "flexcloud/ros/bag_input.h"
#include "flexcloud/ros/conversions.h"
#include "flexcloud/sim/drive_simulator.h"
#include "test_util.h"

namespace flexcloud {
namespace {

namespace fs = std::filesystem;

const sim::SimDrive& drive() {
  static const sim::SimDrive d = [] {
    sim::SimParams sp;
    sp.length = 300.0;
    sp.map_points = 0;
    return sim::simulateDrive(sp);
  }();
  return d;
}

std::string bagPath(const std::string& name) {
  return (fs::path(::testing::TempDir()) / (name + "_" + std::to_string(::getpid()) + ".bag"))
      .string();
}

void writeFixes(rosbag::Bag& bag, const std::string& topic) {
  for (const auto& f : drive().fixes) {
    const auto m = ros_conv::toNavSatFix(f, "gnss");
    bag.write(topic, m.header.stamp, m);
  }
}

std::string errorOf(const std::string& path, BagTopics topics = {}) {
  DriveCollector c;
  return test::errorOf([&] { readBag(path, topics, c); });
}

TEST(BagInput, SeveralCandidateTopicsAskForAChoice) {
  ros::Time::init();
  const std::string path = bagPath("two_fixes");
  {
    rosbag::Bag bag(path, rosbag::bagmode::Write);
    writeFixes(bag, "/gnss/fix");
    writeFixes(bag, "/gps/fix");
    for (const auto& p : drive().slam) {
      const auto m = ros_conv::toOdometry(p, "map", "base");
      bag.write("/odom", m.header.stamp, m);
    }
  }
  const std::string e = errorOf(path);
  EXPECT_NE(e.find("several GNSS fix topics (/gnss/fix, /gps/fix); choose one with --fix-topic"),
            std::string::npos)
      << e;
  BagTopics topics;
  topics.fix = "gps/fix";  // relative names are taken as absolute
  DriveCollector c;
  const BagSummary s = readBag(path, topics, c);
  EXPECT_EQ(s.fix_topic, "/gps/fix");
  EXPECT_EQ(c.fixCount(), drive().fixes.size());
  EXPECT_EQ(c.poseCount(), drive().slam.size());
}

TEST(BagInput, PoseStampedAndTheLastPathAreRead) {
  const std::string pose_bag = bagPath("poses"), path_bag = bagPath("paths");
  {
    rosbag::Bag a(pose_bag, rosbag::bagmode::Write), b(path_bag, rosbag::bagmode::Write);
    writeFixes(a, "/fix");
    writeFixes(b, "/fix");
    for (const auto& p : drive().slam) {
      const auto o = ros_conv::toOdometry(p, "map", "base");
      geometry_msgs::PoseStamped ps;
      ps.header = o.header;
      ps.pose = o.pose.pose;
      a.write("/slam/pose", ps.header.stamp, ps);
    }
    // Two paths: an early partial one and the final optimized one, which must win.
    Trajectory half(drive().slam.begin(), drive().slam.begin() + 10);
    b.write("/slam/path", ros_conv::toTime(half.back().stamp), ros_conv::toPath(half, "map"));
    b.write("/slam/path", ros_conv::toTime(drive().slam.back().stamp),
            ros_conv::toPath(drive().slam, "map"));
  }
  DriveCollector ca, cb;
  EXPECT_EQ(readBag(pose_bag, {}, ca).odom_type, "geometry_msgs/PoseStamped");
  EXPECT_EQ(ca.poseCount(), drive().slam.size());
  EXPECT_EQ(readBag(path_bag, {}, cb).odom_type, "nav_msgs/Path");
  EXPECT_EQ(cb.poseCount(), drive().slam.size());
  EXPECT_EQ(cb.mapFrame(), "map");
}

TEST(BagInput, AForgedVectorLengthIsAnErrorNotAnAllocation) {
  const std::string path = bagPath("forged");
  nav_msgs::Path msg =
      ros_conv::toPath(Trajectory(drive().slam.begin(), drive().slam.begin() + 3), "map");
  {
    rosbag::Bag bag(path, rosbag::bagmode::Write);
    writeFixes(bag, "/fix");
    bag.write("/path", msg.header.stamp, msg);
  }
  // The poses count sits right after the header (seq, stamp, "map"): make it claim 2^31 poses.
  std::string bytes;
  {
    std::ifstream in(path, std::ios::binary);
    bytes.assign((std::istreambuf_iterator<char>(in)), {});
  }
  const std::string frame("\x03\x00\x00\x00map", 7);
  std::size_t at = 0, forged = 0;
  while ((at = bytes.find(frame, at)) != std::string::npos) {
    const std::size_t count = at + frame.size();
    if (count + 4 <= bytes.size() && bytes[count] == 3 && bytes[count + 1] == 0) {
      bytes[count + 3] = static_cast<char>(0x80);
      ++forged;
    }
    at = count;
  }
  ASSERT_GE(forged, 1u);
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
  const std::string e = errorOf(path);
  EXPECT_NE(e.find("holds a vector longer than the message"), std::string::npos) << e;
}

TEST(BagInput, ACutOrCorruptBagNamesTheByte) {
  const std::string good = bagPath("good"), cut = bagPath("cut");
  {
    rosbag::Bag bag(good, rosbag::bagmode::Write);
    writeFixes(bag, "/fix");
  }
  std::ifstream in(good, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), {});
  for (std::size_t keep : {bytes.size() / 2, bytes.size() - 100, std::size_t{20}}) {
    std::ofstream(cut, std::ios::binary | std::ios::trunc) << bytes.substr(0, keep);
    const std::string e = errorOf(cut);
    EXPECT_NE(e.find(cut), std::string::npos) << e;
    EXPECT_TRUE(e.find("byte") != std::string::npos || e.find("reindex") != std::string::npos) << e;
  }
}

}  // namespace
}  // namespace flexcloud
