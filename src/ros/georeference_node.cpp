#include "flexcloud/ros/georeference_node.h"

#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Path.h>
#include <pcl_conversions/pcl_conversions.h>
#include <visualization_msgs/MarkerArray.h>

#include "flexcloud/io/param_table.h"
#include "flexcloud/io/pcd_io.h"
#include "flexcloud/ros/bag_input.h"
#include "flexcloud/ros/conversions.h"
#include "flexcloud/ros/markers.h"

namespace flexcloud {
namespace {

flexcloud::Deviation toMsg(const ErrorStats& s) {
  flexcloud::Deviation d;
  d.mae = s.mae;
  d.std = s.std;
  d.max = s.max;
  d.rmse = s.rmse;
  d.count = static_cast<std::uint32_t>(s.count);
  return d;
}

flexcloud::Georeference::Response failure(const std::string& message) {
  flexcloud::Georeference::Response r;
  r.success = false;
  r.message = message;
  return r;
}

XyzLayout layoutOf(const sensor_msgs::PointCloud2& msg, const std::string& name) {
  std::vector<pcl::PCLPointField> fields;
  pcl_conversions::toPCL(msg.fields, fields);
  return XyzLayout::of(fields, msg.point_step, static_cast<std::size_t>(msg.width) * msg.height,
                       msg.data.size(), name);
}

/// Stops a bag read when the node shuts down.
struct BagStopped {};

void toConfig(const Params& p, GeoreferenceConfig& c) {
  c.control_points = p.control_points;
  c.refine_fraction = p.refine_fraction;
  c.stddev_threshold = p.stddev_threshold;
  c.margin_x = p.margin_x;
  c.margin_y = p.margin_y;
  c.margin_z = p.margin_z;
  c.margin_min = p.margin_min;
  c.interpolation = toString(p.interpolation);
  c.min_spacing = p.min_spacing;
  c.max_gap = p.max_gap;
}

/// The tunable fields of the config over `p`; throws Error for an unknown interpolation.
Params fromConfig(const GeoreferenceConfig& c, Params p) {
  p.control_points = c.control_points;
  p.refine_fraction = c.refine_fraction;
  p.stddev_threshold = c.stddev_threshold;
  p.margin_x = c.margin_x;
  p.margin_y = c.margin_y;
  p.margin_z = c.margin_z;
  p.margin_min = c.margin_min;
  p.interpolation = parseInterpolationMode(c.interpolation);
  p.min_spacing = c.min_spacing;
  p.max_gap = c.max_gap;
  return p;
}

bool sameScalars(Params a, Params b) {
  const auto ra = paramRefs(a), rb = paramRefs(b);
  for (std::size_t i = 0; i < ra.size(); ++i) {
    if (ra[i].d && *ra[i].d != *rb[i].d && !(std::isnan(*ra[i].d) && std::isnan(*rb[i].d))) return false;
    if (ra[i].i && *ra[i].i != *rb[i].i) return false;
    if (ra[i].mode && *ra[i].mode != *rb[i].mode) return false;
  }
  return true;
}

}  // namespace

GeoreferenceNode::GeoreferenceNode(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(nh), pnh_(pnh), service_nh_(pnh), name_(pnh.getNamespace()),
      params_(loadNodeParams(pnh)), collector_(static_cast<std::size_t>(params_.max_messages)) {
  // Services get their own queue and two threads: a georeference call waits for the worker
  // while the subscribers keep running, and a second call is answered (refused) at once.
  service_nh_.setCallbackQueue(&service_queue_);
  advertise();
  reconfigure_ = std::make_unique<dynamic_reconfigure::Server<GeoreferenceConfig>>(config_mutex_, pnh_);
  pushConfig(params_.core);
  reconfigure_->setCallback(
      [this](GeoreferenceConfig& c, uint32_t level) { onReconfigure(c, level); });
  subscribe();
  worker_ = std::thread([this] { workerLoop(); });
  service_spinner_ = std::make_unique<ros::AsyncSpinner>(2, &service_queue_);
  service_spinner_->start();
  ROS_INFO("%s: ready (%s input, %d control points, std-dev threshold %.3f m)", name_.c_str(),
           params_.bag.empty() ? "live" : ("bag " + params_.bag).c_str(),
           params_.core.control_points, params_.core.stddev_threshold);
}

GeoreferenceNode::~GeoreferenceNode() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  // The worker finishes a run in progress and answers a waiting call before it ends, so no
  // service thread is left waiting when the spinner stops; then no callback may start once the
  // members it uses begin to go.
  if (bag_thread_.joinable()) bag_thread_.join();
  if (worker_.joinable()) worker_.join();
  for (auto& s : subscribers_) s.shutdown();
  for (auto& s : services_) s.shutdown();
  service_nh_.shutdown();
  if (service_spinner_) service_spinner_->stop();
  reconfigure_.reset();
}

void GeoreferenceNode::advertise() {
  map_pub_ = pnh_.advertise<sensor_msgs::PointCloud2>("global_map", 1, true);
  origin_pub_ = pnh_.advertise<sensor_msgs::NavSatFix>("origin", 1, true);
  path_gnss_pub_ = pnh_.advertise<nav_msgs::Path>("path_gnss", 1, true);
  path_slam_pub_ = pnh_.advertise<nav_msgs::Path>("path_slam", 1, true);
  path_aligned_pub_ = pnh_.advertise<nav_msgs::Path>("path_aligned", 1, true);
  path_sheet_pub_ = pnh_.advertise<nav_msgs::Path>("path_rubbersheet", 1, true);
  cp_pub_ = pnh_.advertise<visualization_msgs::MarkerArray>("control_points", 1, true);
  tet_pub_ = pnh_.advertise<visualization_msgs::MarkerArray>("tetrahedra", 1, true);
  dev_pub_ = pnh_.advertise<visualization_msgs::MarkerArray>("deviation", 1, true);
  services_.push_back(
      service_nh_.advertiseService("georeference", &GeoreferenceNode::onGeoreference, this));
  services_.push_back(service_nh_.advertiseService("save", &GeoreferenceNode::onSave, this));
  services_.push_back(service_nh_.advertiseService("reset", &GeoreferenceNode::onReset, this));
}

void GeoreferenceNode::subscribe() {
  const int q = params_.queue_size;
  if (!params_.bag.empty()) {
    bag_done_ = false;
    bag_thread_ = std::thread([this] { readBagThread(); });
  } else {
    using namespace sensor_msgs;
    subscribers_.push_back(nh_.subscribe<NavSatFix>(
        "fix", q, boost::function<void(const NavSatFixConstPtr&)>(
                      [this](const NavSatFixConstPtr& m) { collector_.handleFix(*m); })));
    if (params_.odom_type == "odometry") {
      subscribers_.push_back(nh_.subscribe<nav_msgs::Odometry>(
          "odom", q, boost::function<void(const nav_msgs::OdometryConstPtr&)>(
                         [this](const nav_msgs::OdometryConstPtr& m) { collector_.handleOdometry(*m); })));
    } else if (params_.odom_type == "pose") {
      subscribers_.push_back(nh_.subscribe<geometry_msgs::PoseStamped>(
          "odom", q, boost::function<void(const geometry_msgs::PoseStampedConstPtr&)>(
                         [this](const geometry_msgs::PoseStampedConstPtr& m) { collector_.handlePose(*m); })));
    } else {
      subscribers_.push_back(nh_.subscribe<nav_msgs::Path>(
          "odom", q, boost::function<void(const nav_msgs::PathConstPtr&)>(
                         [this](const nav_msgs::PathConstPtr& m) { collector_.handlePath(*m); })));
    }
  }
  if (params_.map_file.empty()) {
    subscribers_.push_back(nh_.subscribe("map", 1, &GeoreferenceNode::onMap, this));
  }
}

void GeoreferenceNode::onMap(const sensor_msgs::PointCloud2ConstPtr& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  map_ = msg;  // a run in progress keeps the cloud it started with
}

void GeoreferenceNode::readBagThread() {
  BagTopics topics;
  topics.fix = nh_.resolveName("fix");
  topics.odom = nh_.resolveName("odom");
  pcl::PCLPointCloud2 cloud;
  std::string error;
  try {
    const BagSummary s = flexcloud::readBag(params_.bag, topics, collector_, nullptr, [this](double) {
      std::lock_guard<std::mutex> lock(mutex_);
      if (stop_) throw BagStopped{};
    });
    ROS_INFO("%s: read %zu fixes and %zu poses from %s", name_.c_str(), s.fixes, s.poses,
             params_.bag.c_str());
  } catch (const BagStopped&) {
    return;
  } catch (const Error& e) {
    error = e.what();
    ROS_ERROR("%s: %s", name_.c_str(), error.c_str());
  }
  std::lock_guard<std::mutex> lock(mutex_);
  bag_done_ = true;
  bag_error_ = error;
  if (error.empty() && params_.georeference_on_bag_end && !busy_ && !service_job_) {
    service_job_ = Job{params_.core, nullptr};
    wake_.notify_all();
  }
}

void GeoreferenceNode::loadMapFile() {
  std::string error;
  sensor_msgs::PointCloud2Ptr msg(new sensor_msgs::PointCloud2);
  try {
    pcl::PCLPointCloud2 cloud = readPcd(params_.map_file);
    pcl_conversions::moveFromPCL(cloud, *msg);
    layoutOf(*msg, params_.map_file);
    ROS_INFO("%s: loaded %u points from %s", name_.c_str(), msg->width * msg->height,
             params_.map_file.c_str());
  } catch (const Error& e) {
    error = "map_file " + std::string(e.what());
    ROS_ERROR("%s: %s", name_.c_str(), error.c_str());
  }
  std::lock_guard<std::mutex> lock(mutex_);
  if (error.empty()) map_ = msg;
  map_error_ = error;
}

void GeoreferenceNode::workerLoop() {
  if (!params_.map_file.empty()) loadMapFile();
  while (true) {
    Job job;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      while (!stop_ && !service_job_ &&
             !(recompute_pending_ && std::chrono::steady_clock::now() >= recompute_at_)) {
        if (recompute_pending_) {
          wake_.wait_until(lock, recompute_at_);
        } else {
          wake_.wait(lock);
        }
      }
      if (stop_) break;
      if (service_job_) {
        job = std::move(*service_job_);
        service_job_.reset();
      } else {
        job.params = params_.core;  // the latest setting wins
      }
      recompute_pending_ = false;
      busy_ = true;
    }
    flexcloud::Georeference::Response reply;
    std::shared_ptr<const State> state;
    try {
      state = run(job.params);
      reply = describe(*state);
    } catch (const std::exception& e) {
      reply = failure(e.what());
      ROS_ERROR("%s: georeferencing failed: %s", name_.c_str(), e.what());
    }
    if (state) publish(*state);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (state) state_ = state;
      busy_ = false;
    }
    if (job.reply) job.reply->set_value(reply);
  }
  std::lock_guard<std::mutex> lock(mutex_);
  if (service_job_ && service_job_->reply) {
    service_job_->reply->set_value(failure("the node is shutting down"));
  }
  service_job_.reset();
}

std::shared_ptr<const GeoreferenceNode::State> GeoreferenceNode::run(const Params& params) {
  const auto t0 = std::chrono::steady_clock::now();
  auto s = std::make_shared<State>();
  const DriveInput input = collector_.snapshot();
  if (input.fixes.empty()) {
    throw Error("no GNSS fix received yet on " +
                (params_.bag.empty() ? nh_.resolveName("fix") : params_.bag));
  }
  if (input.poses.empty()) {
    throw Error("no pose received yet on " +
                (params_.bag.empty() ? nh_.resolveName("odom") : params_.bag));
  }
  s->result = flexcloud::georeference(input, params);
  s->params = params;
  s->frames.enu = params_.enu_frame;
  s->frames.map = !params_.map_frame.empty() ? params_.map_frame
                  : !collector_.mapFrame().empty() ? collector_.mapFrame()
                                                   : std::string("map");
  sensor_msgs::PointCloud2ConstPtr map;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!map_error_.empty()) throw Error(map_error_);
    map = map_;
  }
  if (map) {
    const auto tw = std::chrono::steady_clock::now();
    sensor_msgs::PointCloud2Ptr warped(new sensor_msgs::PointCloud2(*map));
    const XyzLayout layout = layoutOf(*warped, params_.map_file.empty() ? "map topic" : params_.map_file);
    s->map_info.input = params_.map_file.empty() ? nh_.resolveName("map") : params_.map_file;
    s->map_info.warp = warpPoints(warped->data.data(), layout, *s->result.sheet, params.threads);
    s->map_info.warp_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - tw).count();
    warped->header.frame_id = params_.enu_frame;
    warped->header.stamp = ros::Time::now();
    s->map = warped;
  }
  s->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return s;
}

void GeoreferenceNode::publish(const State& s) {
  const auto& r = s.result;
  const ros::Time now = ros::Time::now();
  const std::string& enu = s.frames.enu;
  if (s.map) map_pub_.publish(s.map);
  geometry_msgs::TransformStamped tf;
  tf.header.stamp = now;
  tf.header.frame_id = enu;
  tf.child_frame_id = s.frames.map;
  const geometry_msgs::Pose pose = ros_conv::toPoseMsg(r.T_enu_map);
  tf.transform.translation.x = pose.position.x;
  tf.transform.translation.y = pose.position.y;
  tf.transform.translation.z = pose.position.z;
  tf.transform.rotation = pose.orientation;
  tf_.sendTransform(tf);
  if (r.datum) {
    RawFix origin;
    origin.fix = GeoFix{now.toSec(), r.datum->lat, r.datum->lon, r.datum->alt,
                        Eigen::Vector3d::Zero()};
    auto msg = ros_conv::toNavSatFix(origin, enu);
    msg.position_covariance_type = sensor_msgs::NavSatFix::COVARIANCE_TYPE_UNKNOWN;
    origin_pub_.publish(msg);
  }
  std::vector<Eigen::Vector3d> gnss;
  std::vector<double> stamps;
  for (std::size_t i = 0; i < r.poses.size(); ++i) {
    if (!r.gnss_at_pose[i]) continue;
    gnss.push_back(r.gnss_at_pose[i]->position);
    stamps.push_back(r.poses[i].stamp);
  }
  path_gnss_pub_.publish(ros_conv::toPath(gnss, stamps, enu));
  path_slam_pub_.publish(ros_conv::toPath(r.poses, s.frames.map));
  path_aligned_pub_.publish(ros_conv::toPath(r.aligned, enu));
  path_sheet_pub_.publish(ros_conv::toPath(r.rubbersheet, enu));
  cp_pub_.publish(markers::controlPoints(r, enu, now));
  tet_pub_.publish(markers::tetrahedra(r, enu, now));
  dev_pub_.publish(markers::deviation(r, enu, now));
  ROS_INFO("%s: georeferenced %zu poses with %zu control points: MAE %.3f m (rigid only %.3f m)%s",
           name_.c_str(), r.poses.size(), r.control_points.points.size(),
           r.metrics_rubbersheet.mae, r.metrics_aligned.mae,
           s.map ? (", map of " + std::to_string(s.map_info.warp.points) + " points").c_str() : "");
}

flexcloud::Georeference::Response GeoreferenceNode::describe(const State& s) const {
  const auto& r = s.result;
  flexcloud::Georeference::Response res;
  res.success = true;
  res.message = "georeferenced " + std::to_string(r.poses.size()) + " poses with " +
                std::to_string(r.control_points.points.size()) + " control points" +
                (s.map ? " and a map of " + std::to_string(s.map_info.warp.points) + " points"
                       : " (no map yet)") +
                (r.revisits.conflicting > 0
                     ? "; warning: " + std::to_string(r.revisits.conflicting) +
                           " control point pairs revisit places the SLAM map puts elsewhere on "
                           "another pass: close those loops in the SLAM"
                     : std::string());
  res.fixes_used = static_cast<std::uint32_t>(r.gnss.points.size());
  res.fixes_dropped = static_cast<std::uint32_t>(r.gnss.dropped.total());
  res.poses = static_cast<std::uint32_t>(r.poses.size());
  res.poses_matched = static_cast<std::uint32_t>(r.poses_matched);
  res.control_points = static_cast<std::uint32_t>(r.control_points.points.size());
  res.map_points = s.map_info.warp.points;
  res.points_outside = s.map_info.warp.outside;
  res.aligned = toMsg(r.metrics_aligned);
  res.rubbersheet = toMsg(r.metrics_rubbersheet);
  const geometry_msgs::Pose pose = ros_conv::toPoseMsg(r.T_enu_map);
  res.T_enu_map.translation.x = pose.position.x;
  res.T_enu_map.translation.y = pose.position.y;
  res.T_enu_map.translation.z = pose.position.z;
  res.T_enu_map.rotation = pose.orientation;
  res.scale = r.scale;
  if (r.datum) {
    res.datum_lat = r.datum->lat;
    res.datum_lon = r.datum->lon;
    res.datum_alt = r.datum->alt;
  }
  res.seconds = s.seconds;
  return res;
}

flexcloud::Georeference::Response GeoreferenceNode::georeference(int control_points,
                                                                 double stddev_threshold) {
  auto reply = std::make_shared<std::promise<flexcloud::Georeference::Response>>();
  auto future = reply->get_future();
  Params params;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stop_) return failure("the node is shutting down");
    if (busy_ || service_job_) {
      return failure("a georeferencing run is going; call again when it has finished");
    }
    if (!bag_done_) return failure("still reading the bag " + params_.bag + "; call again soon");
    if (!bag_error_.empty()) return failure(bag_error_);
    params = params_.core;
    if (control_points > 0) params.control_points = control_points;
    if (stddev_threshold > 0.0) params.stddev_threshold = stddev_threshold;
    if (control_points < 0 || stddev_threshold < 0.0 || !std::isfinite(stddev_threshold)) {
      return failure("control_points and stddev_threshold must be 0 (keep) or positive");
    }
    if (const std::string bad = params.validate(); !bad.empty()) return failure(bad);
    params_.core = params;
    service_job_ = Job{params, reply};
  }
  wake_.notify_all();
  pushConfig(params);
  return future.get();
}

flexcloud::Save::Response GeoreferenceNode::save(const std::string& dir) {
  flexcloud::Save::Response res;
  std::shared_ptr<const State> s;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    s = state_;
  }
  if (!s) {
    res.message = "no result yet: call georeference first";
    return res;
  }
  if (dir.empty()) {
    res.message = "directory is empty";
    return res;
  }
  try {
    MapWriter write_map;
    if (s->map) {
      write_map = [&](const std::string& path) {
        std::vector<pcl::PCLPointField> fields;
        pcl_conversions::toPCL(s->map->fields, fields);
        writePcdBinary(path, fields, s->map->point_step, s->map->width, s->map->height,
                       s->map->data.data(), s->map->data.size());
      };
    }
    writeOutputs(dir, s->result, s->params, write_map, s->map ? &s->map_info : nullptr,
                 s->frames);
    res.success = true;
    res.message = "wrote the result into " + dir;
  } catch (const std::exception& e) {
    res.message = e.what();
  }
  return res;
}

void GeoreferenceNode::reset() {
  collector_.clear();
  ROS_INFO("%s: cleared every fix and pose collected so far", name_.c_str());
}

// The callbacks answer every call: an exception becomes success false with its message
// (returning false or throwing would leave the caller with a bare transport failure).
template <typename Response, typename F>
bool answer(Response& res, const std::string& name, F&& f) {
  try {
    f();
  } catch (const std::exception& e) {
    ROS_ERROR("%s: %s", name.c_str(), e.what());
    res.success = false;
    res.message = e.what();
  }
  return true;
}

bool GeoreferenceNode::onGeoreference(flexcloud::Georeference::Request& req,
                                      flexcloud::Georeference::Response& res) {
  return answer(res, name_, [&] { res = georeference(req.control_points, req.stddev_threshold); });
}

bool GeoreferenceNode::onSave(flexcloud::Save::Request& req, flexcloud::Save::Response& res) {
  return answer(res, name_, [&] { res = save(req.directory); });
}

bool GeoreferenceNode::onReset(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  return answer(res, name_, [&] {
    reset();
    res.success = true;
    res.message = "cleared";
  });
}

void GeoreferenceNode::pushConfig(const Params& p) {
  GeoreferenceConfig c;
  {
    boost::recursive_mutex::scoped_lock lock(config_mutex_);
    reconfigure_->getConfigDefault(c);
  }
  toConfig(p, c);
  reconfigure_->updateConfig(c);
}

void GeoreferenceNode::onReconfigure(GeoreferenceConfig& c, uint32_t /*level*/) {
  std::lock_guard<std::mutex> lock(mutex_);
  Params p;
  std::string bad;
  try {
    p = fromConfig(c, params_.core);
    bad = p.validate();
  } catch (const Error& e) {
    bad = e.what();
  }
  if (!bad.empty()) {
    ROS_ERROR("%s: dynamic_reconfigure change refused: %s", name_.c_str(), bad.c_str());
    toConfig(params_.core, c);  // the server shows the values in use
    return;
  }
  const bool changed = !sameScalars(p, params_.core);
  params_.core = p;
  if (changed && state_) {
    recompute_pending_ = true;
    recompute_at_ = std::chrono::steady_clock::now() +
                    std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                        std::chrono::duration<double>(params_.recompute_delay));
    wake_.notify_all();
  }
}

}  // namespace flexcloud
