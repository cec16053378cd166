// simulate_drive: writes a simulated drive with its ground truth into a folder:
//   drive.bag              /fix (sensor_msgs/NavSatFix), /odom (nav_msgs/Odometry, frame "map";
//                          or PoseStamped / a final Path with --odom-type), optionally /map
//   map.pcd                the SLAM map (drifted), binary
//   truth_map.pcd          the same points in the same order, true ENU of the datum (float64)
//   gnss.txt               the fixes as text (NO_FIX ones left out), slam_trajectory.txt and
//   truth_trajectory.txt   (TUM), truth.yaml (datum and settings)

#include <ros/time.h>
#include <rosbag/bag.h>

#include <iomanip>
#include <iostream>
#include <sstream>

#include "cli.h"
#include "flexcloud/io/atomic_file.h"
#include "flexcloud/io/keyframes.h"
#include "flexcloud/io/pcd_io.h"
#include "flexcloud/io/text_io.h"
#include "flexcloud/param_table.h"
#include "flexcloud/ros/conversions.h"
#include "flexcloud/sim/scenarios.h"
#include "flexcloud/sim/sim_cloud.h"

namespace {

using namespace flexcloud;
using cli::UsageError;

constexpr const char* kUsage = R"(usage: simulate_drive [options]
  --out DIR               output folder (default: sim_out)
  --scenario NAME         start from a drive of the accuracy study (doc/ACCURACY.md), e.g.
                          loop_urban, race_track, loop_unclosed; the options after it change it
  --seed N                random seed (default 1)
  --open                  open A-to-B route without loop closure (default: loop, loop-closed)
  --length M              route length, one lap (default 5000 m)
  --laps N                laps of the loop (default 1; loop closure only at the very end)
  --elevation F           scale of the hills (default 1; 0: a level road)
  --speed V               m/s (default 12)
  --stop S                stand still S seconds halfway
  --map-points N          map points (default 200000)
  --odom-rate HZ          (default 10)   --gnss-rate HZ (default 5)
  --gnss-noise H V        GNSS noise 1-sigma, m (default 0.015 0.03)
  --reported-std H V      std-devs put in the covariance (default: the noise)
  --outage A:B            degraded GNSS from A to B seconds after the start (repeatable)
  --no-fix A:B            NO_FIX messages from A to B seconds (repeatable)
  --clock-offset S        SLAM clock minus GNSS clock, as gnss_time_offset (default 0):
                          georeference --set gnss_time_offset=S undoes it
  --heading-bias D        deg per 100 m (default 0.1)   --pitch-bias D (default 0.04)
  --scale-error F         (default 0.002)
  --pose-jitter S         white noise on every SLAM pose's position, m per axis (default 0)
  --odom-type T           odometry (default), pose or path
  --fix-topic T           topic of the fixes in the bag (default /fix)
  --odom-topic T          topic of the poses in the bag (default /odom)
  --map-topic             also put the SLAM map into the bag on /map (PointCloud2)
  --map-time              give every map point a float64 field time: the odometry stamp of
                          the scan that saw it (georeference then rebuilds the map from it)
  --scans                 also put the map into the bag as the SLAM's registered scans on
                          /scans (PointCloud2 in the map frame, one per pose, its stamp)
  --body-scans            the same in the body's frame (base_link), as the LiDAR saw them
  --keyframes             also write the map as a keyframe SLAM's dump: keyframes/NNNNNN/data
                          (stamp, pose) and cloud.pcd (its points in its own frame), for
                          georeference --keyframes
  -h, --help
)";

struct Options {
  sim::SimParams sim;
  std::string out = "sim_out";
  std::string odom_type = "odometry";
  std::string fix_topic = "/fix";
  std::string odom_topic = "/odom";
  bool map_topic = false;
  bool map_time = false;
  bool keyframes = false;
  bool scans = false;
  bool body_scans = false;
};

Options parse(int argc, char** argv) {
  Options o;
  auto& s = o.sim;
  cli::forEachFlag(argc, argv, kUsage, [&](const std::string& f, cli::Args& a) {
    if (f == "--scenario") {
      s = sim::scenario(a.text(f), s.seed, s.map_points);
    } else if (f == "--out") {
      o.out = a.text(f);
    } else if (f == "--seed") {
      s.seed = static_cast<std::uint64_t>(a.integer(f));
    } else if (f == "--open") {
      s.loop = false;
    } else if (f == "--length") {
      s.length = a.number(f);
    } else if (f == "--laps") {
      s.laps = static_cast<int>(a.integer(f));
    } else if (f == "--elevation") {
      s.elevation = a.number(f);
    } else if (f == "--speed") {
      s.speed = a.number(f);
    } else if (f == "--stop") {
      s.stop_duration = a.number(f);
    } else if (f == "--map-points") {
      const long n = a.integer(f);
      if (n < 0) throw UsageError("--map-points must not be negative");
      s.map_points = static_cast<std::size_t>(n);
    } else if (f == "--odom-rate") {
      s.odom_rate = a.number(f);
    } else if (f == "--gnss-rate") {
      s.gnss_rate = a.number(f);
    } else if (f == "--gnss-noise") {
      s.gnss_noise_h = a.number(f);
      s.gnss_noise_v = a.number(f);
    } else if (f == "--reported-std") {
      s.reported_std_h = a.number(f);
      s.reported_std_v = a.number(f);
    } else if (f == "--outage") {
      for (const auto& r : parseTimeRanges(f, a.text(f))) s.outages.push_back(r);
    } else if (f == "--no-fix") {
      for (const auto& r : parseTimeRanges(f, a.text(f))) s.no_fix.push_back(r);
    } else if (f == "--clock-offset") {
      s.clock_offset = a.number(f);
    } else if (f == "--heading-bias") {
      s.heading_bias = a.number(f);
    } else if (f == "--pitch-bias") {
      s.pitch_bias = a.number(f);
    } else if (f == "--scale-error") {
      s.scale_error = a.number(f);
    } else if (f == "--pose-jitter") {
      s.slam_errors.pose_jitter = a.number(f);
    } else if (f == "--odom-type") {
      o.odom_type = a.text(f);
      if (o.odom_type != "odometry" && o.odom_type != "pose" && o.odom_type != "path") {
        throw UsageError("--odom-type: '" + o.odom_type + "' is not odometry, pose or path");
      }
    } else if (f == "--fix-topic") {
      o.fix_topic = a.text(f);
    } else if (f == "--odom-topic") {
      o.odom_topic = a.text(f);
    } else if (f == "--map-topic") {
      o.map_topic = true;
    } else if (f == "--map-time") {
      o.map_time = true;
    } else if (f == "--keyframes") {
      o.keyframes = true;
    } else if (f == "--scans") {
      o.scans = true;
    } else if (f == "--body-scans") {
      o.scans = o.body_scans = true;
    } else {
      return false;
    }
    return true;
  });
  return o;
}

void writeBag(const std::string& path, const sim::SimDrive& d, const Options& o,
              const pcl::PCLPointCloud2* map) {
  AtomicFile file(path);
  {
    rosbag::Bag bag(file.tempPath(), rosbag::bagmode::Write);
    for (const auto& f : d.fixes) {
      const auto msg = ros_conv::toNavSatFix(f, "gnss");
      bag.write(o.fix_topic, msg.header.stamp, msg);
    }
    for (const auto& p : d.slam) {
      const auto odom = ros_conv::toOdometry(p, "map", "base_link");
      if (o.odom_type == "odometry") {
        bag.write(o.odom_topic, odom.header.stamp, odom);
      } else if (o.odom_type == "pose") {
        geometry_msgs::PoseStamped ps;
        ps.header = odom.header;
        ps.pose = odom.pose.pose;
        bag.write(o.odom_topic, ps.header.stamp, ps);
      }
    }
    if (o.odom_type == "path") {
      const auto path_msg = ros_conv::toPath(d.slam, "map");
      bag.write(o.odom_topic, path_msg.header.stamp, path_msg);
    }
    const auto scans = !o.scans       ? decltype(sim::registeredScans(d)){}
                       : o.body_scans ? sim::keyframeClouds(d)
                                      : sim::registeredScans(d);
    for (const auto& [pose, scan] : scans) {
      sensor_msgs::PointCloud2 msg;
      ros_conv::toCloudMsg(scan, o.body_scans ? "base_link" : "map", msg);
      msg.header.stamp = ros_conv::toTime(pose.stamp);
      bag.write("/scans", msg.header.stamp, msg);
    }
    if (map != nullptr) {
      sensor_msgs::PointCloud2 msg;
      ros_conv::toCloudMsg(*map, "map", msg);
      msg.header.stamp = ros_conv::toTime(d.slam.back().stamp);
      bag.write("/map", msg.header.stamp, msg);
    }
    bag.close();
  }
  file.commit();
}

std::string gnssText(const sim::SimDrive& d) {
  std::ostringstream s;
  s << "# stamp[s] lat[deg] lon[deg] alt[m] std_e std_n std_u [m]\n" << std::fixed;
  for (const auto& f : d.fixes) {
    if (!f.has_fix) continue;
    s << std::setprecision(6) << f.fix.stamp << ' ' << std::setprecision(10) << f.fix.lat << ' '
      << f.fix.lon << ' ' << std::setprecision(4) << f.fix.alt << ' ' << f.fix.std_enu.x() << ' '
      << f.fix.std_enu.y() << ' ' << f.fix.std_enu.z() << '\n';
  }
  return s.str();
}

std::string truthYaml(const sim::SimDrive& d) {
  const auto& p = d.params;
  std::ostringstream s;
  s << std::setprecision(12);
  s << "# Ground truth of a simulated drive: truth_map.pcd and truth_trajectory.txt are in the\n"
       "# ENU frame of this datum.\n";
  s << "datum:\n  latitude: " << d.datum.lat << "\n  longitude: " << d.datum.lon
    << "\n  altitude: " << d.datum.alt << "\n";
  s << "route: " << (p.loop ? "loop" : "open") << "\nlength: " << p.length << "\nseed: " << p.seed
    << "\nclock_offset: " << p.clock_offset
    << "  # SLAM clock minus GNSS clock (s), as gnss_time_offset\nmap_points: " << p.map_points
    << "\n";
  return s.str();
}

/// The map as a keyframe SLAM's dump (keyframes.h): a folder per pose that saw points.
void writeKeyframeDump(const std::string& dir, const sim::SimDrive& d) {
  const auto keyframes = sim::keyframeClouds(d);
  for (std::size_t i = 0; i < keyframes.size(); ++i) {
    char name[16];
    std::snprintf(name, sizeof(name), "/%06zu", i);
    const std::string kf = dir + name;
    makeDirectories(kf);
    writeTextFile(kf + "/data", keyframeDataText(keyframes[i].first));
    writePcdBinary(kf + "/cloud.pcd", keyframes[i].second);
  }
}

int run(int argc, char** argv) {
  const Options o = parse(argc, argv);
  const sim::SimDrive d = sim::simulateDrive(o.sim);
  makeDirectories(o.out);
  const pcl::PCLPointCloud2 map = sim::slamCloud(d.map, o.map_time);
  writeBag(o.out + "/drive.bag", d, o, o.map_topic ? &map : nullptr);
  writePcdBinary(o.out + "/map.pcd", map);
  writePcdBinary(o.out + "/truth_map.pcd", sim::truthCloud(d.map));
  writeTextFile(o.out + "/gnss.txt", gnssText(d));
  writeTextFile(o.out + "/slam_trajectory.txt", formatTum(d.slam));
  writeTextFile(o.out + "/truth_trajectory.txt", formatTum(d.truth));
  writeTextFile(o.out + "/truth.yaml", truthYaml(d));
  if (o.keyframes) writeKeyframeDump(o.out + "/keyframes", d);
  std::cout << "simulate_drive: " << (o.sim.loop ? "loop" : "open") << " route of " << o.sim.length
            << " m, " << d.slam.size() << " poses, " << d.fixes.size() << " fixes, "
            << d.map.slam.size() << " map points -> " << o.out << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  ros::Time::init();
  try {
    return run(argc, argv);
  } catch (const UsageError& e) {
    std::cerr << "simulate_drive: " << e.what() << " (see --help)" << std::endl;
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "simulate_drive: " << e.what() << std::endl;
    return 1;
  }
}
