#include "flexcloud/ros/georeference_node.h"

#include <pcl_conversions/pcl_conversions.h>
#include <ros/master.h>

#include <cstdio>
#include <filesystem>
#include <optional>

#include "flexcloud/io/cloud_layout.h"
#include "flexcloud/io/outputs.h"
#include "flexcloud/io/pcd_io.h"
#include "flexcloud/io/report_plot.h"
#include "flexcloud/ros/bag_input.h"
#include "flexcloud/ros/conversions.h"
#include "flexcloud/ros/frame_services.h"
#include "flexcloud/uncertainty/point_sigma.h"

namespace flexcloud {
namespace {

/// Stops a bag read when the node shuts down or resets.
struct BagStopped {};

flexcloud::Result failed(const std::string& message) {
  return toResultMsg(nullptr, false, message);
}

}  // namespace

GeoreferenceNode::GeoreferenceNode(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(nh), pnh_(pnh), service_nh_(pnh), name_(pnh.getNamespace()) {
  // Services get their own queue and two threads: a georeference call waits for the worker
  // while the subscribers keep running, and a second call is answered (refused) at once.
  service_nh_.setCallbackQueue(&service_queue_);
  try {
    params_ = loadNodeParams(pnh);
    for (const auto& name : unknownNodeParams(pnh)) {
      ROS_WARN("%s: parameter '%s' is not one of flexcloud's and is ignored (misspelled?)",
               name_.c_str(), (name_ + "/" + name).c_str());
    }
  } catch (const Error& e) {
    startup_error_ = std::string("not started: ") + e.what();
    ROS_FATAL("%s: %s", name_.c_str(), startup_error_.c_str());
  }
  advertiseServices();
  if (startup_error_.empty()) start();
  service_spinner_ = std::make_unique<ros::AsyncSpinner>(2, &service_queue_);
  service_spinner_->start();
}

NodeParams GeoreferenceNode::params() const {
  GuardedLock lock(mutex_);
  return params_;
}

void GeoreferenceNode::start() {
  const NodeParams p = params();
  collector_.setLimit(static_cast<std::size_t>(p.max_messages));
  publisher_ = std::make_unique<ResultPublisher>(pnh_);
  tf_listener_ = std::make_unique<tf2_ros::TransformListener>(tf_buffer_, nh_);
  publisher_->report(toResultMsg(nullptr, false, "no result yet: call ~georeference"));
  reconfigure_ =
      std::make_unique<dynamic_reconfigure::Server<GeoreferenceConfig>>(config_mutex_, pnh_);
  pushConfig(p);
  reconfigure_->setCallback(
      [this](GeoreferenceConfig& c, uint32_t level) { onReconfigure(c, level); });
  subscribe(p);
  worker_ = std::thread([this] { workerLoop(); });
  ROS_INFO("%s: ready (%s input, %d control points, std-dev threshold %.3f m)", name_.c_str(),
           p.bag.empty() ? "live" : ("bag " + p.bag).c_str(), p.core.control_points,
           p.core.stddev_threshold);
}

GeoreferenceNode::~GeoreferenceNode() {
  {
    GuardedLock lock(mutex_);
    stop_ = true;
    bag_stop_ = true;
    if (run_cancel_) run_cancel_->cancel();  // a run in progress stops at its next check
  }
  wake_.notify_all();
  // The worker answers a waiting call before it ends, so no service thread is left waiting
  // when the spinner stops; then no callback may start once the members it uses begin to go.
  if (bag_thread_.joinable()) bag_thread_.join();
  if (worker_.joinable()) worker_.join();
  for (auto& s : subscribers_) s.shutdown();
  for (auto& s : services_) s.shutdown();
  service_nh_.shutdown();
  if (service_spinner_) service_spinner_->stop();
  reconfigure_.reset();
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

void GeoreferenceNode::advertiseServices() {
  using G = flexcloud::Georeference;
  using S = flexcloud::Save;
  using L = flexcloud::LoadMap;
  using T = std_srvs::Trigger;
  services_.push_back(service_nh_.advertiseService<G::Request, G::Response>(
      "georeference", [this](G::Request& req, G::Response& res) {
        return answer(res, name_,
                      [&] { res = georeference(req.control_points, req.stddev_threshold); });
      }));
  services_.push_back(service_nh_.advertiseService<S::Request, S::Response>(
      "save", [this](S::Request& req, S::Response& res) {
        return answer(res, name_, [&] { res = save(req.directory, req.autoware, req.las); });
      }));
  services_.push_back(service_nh_.advertiseService<T::Request, T::Response>(
      "reset", [this](T::Request&, T::Response& res) {
        return answer(res, name_, [&] { res = reset(); });
      }));
  services_.push_back(service_nh_.advertiseService<L::Request, L::Response>(
      "load_map", [this](L::Request& req, L::Response& res) {
        return answer(res, name_, [&] { res = loadMap(req.file); });
      }));
  advertiseFrameServices();
}

std::shared_ptr<const NodeResult> GeoreferenceNode::latestResult() {
  if (!startup_error_.empty()) throw Error(startup_error_);
  GuardedLock lock(mutex_);
  if (!result_) {
    throw Error("no result: call georeference first (a reset withdraws the result)");
  }
  return result_;
}

void GeoreferenceNode::advertiseFrameServices() {
  services_.push_back(service_nh_.advertiseService<ToLL::Request, ToLL::Response>(
      "to_ll", [this](ToLL::Request& req, ToLL::Response& res) {
        return answer(res, name_, [&] { res = toLL(*latestResult(), req); });
      }));
  services_.push_back(service_nh_.advertiseService<FromLL::Request, FromLL::Response>(
      "from_ll", [this](FromLL::Request& req, FromLL::Response& res) {
        return answer(res, name_, [&] { res = fromLL(*latestResult(), req); });
      }));
  services_.push_back(service_nh_.advertiseService<ToEnu::Request, ToEnu::Response>(
      "to_enu", [this](ToEnu::Request& req, ToEnu::Response& res) {
        return answer(res, name_, [&] { res = toEnu(*latestResult(), req); });
      }));
}

void GeoreferenceNode::subscribe(const NodeParams& p) {
  const int q = p.queue_size;
  if (!p.bag.empty()) {
    startBagRead();
  } else {
    using namespace sensor_msgs;
    subscribers_.push_back(nh_.subscribe<NavSatFix>(
        "fix", q,
        boost::function<void(const NavSatFixConstPtr&)>(
            [this](const NavSatFixConstPtr& m) { collector_.handleFix(*m); })));
    if (p.odom_type == "odometry") {
      subscribers_.push_back(nh_.subscribe<nav_msgs::Odometry>(
          "odom", q,
          boost::function<void(const nav_msgs::OdometryConstPtr&)>(
              [this](const nav_msgs::OdometryConstPtr& m) { collector_.handleOdometry(*m); })));
    } else if (p.odom_type == "pose") {
      subscribers_.push_back(nh_.subscribe<geometry_msgs::PoseStamped>(
          "odom", q,
          boost::function<void(const geometry_msgs::PoseStampedConstPtr&)>(
              [this](const geometry_msgs::PoseStampedConstPtr& m) { collector_.handlePose(*m); })));
    } else {
      subscribers_.push_back(nh_.subscribe<nav_msgs::Path>(
          "odom", q,
          boost::function<void(const nav_msgs::PathConstPtr&)>(
              [this](const nav_msgs::PathConstPtr& m) { collector_.handlePath(*m); })));
    }
  }
  if (p.map_file.empty()) {
    subscribers_.push_back(nh_.subscribe("map", 1, &GeoreferenceNode::onMap, this));
    const std::string scans = nh_.resolveName("scans");
    subscribers_.push_back(nh_.subscribe<sensor_msgs::PointCloud2>(
        "scans", q,
        boost::function<void(const sensor_msgs::PointCloud2ConstPtr&)>(
            [this, scans](const sensor_msgs::PointCloud2ConstPtr& m) { onScan(*m, scans); })));
  }
}

void GeoreferenceNode::onScan(const sensor_msgs::PointCloud2& msg, const std::string& topic) {
  try {
    collector_.handleScan(msg, topic);
  } catch (const Error& e) {  // a scan of other fields: named, the scans so far kept
    ROS_ERROR_THROTTLE(10.0, "%s: %s", name_.c_str(), e.what());
  }
}

void GeoreferenceNode::onMap(const sensor_msgs::PointCloud2ConstPtr& msg) {
  GuardedLock lock(mutex_);
  map_ = msg;  // a run in progress keeps the cloud it started with
}

void GeoreferenceNode::startBagRead() {
  {
    GuardedLock lock(mutex_);
    bag_done_ = false;
    bag_stop_ = false;
    bag_error_.clear();
  }
  bag_thread_ = std::thread([this] { readBag(); });
}

void GeoreferenceNode::readBag() {
  // The configured names (after remapping) are tried first; a bag recorded under other names
  // is read from its only topic of each type, as the offline tool does.
  BagTopics topics;
  topics.fix = nh_.resolveName("fix");
  topics.odom = nh_.resolveName("odom");
  topics.fall_back_by_type = true;
  // Without map_file, the bag's own map (on the map topic, or its only PointCloud2 topic).
  const NodeParams p = params();
  const std::string bag = p.bag;
  pcl::PCLPointCloud2 cloud;
  if (p.map_file.empty()) {
    topics.map = nh_.resolveName("map");
    topics.map_if_any = true;
    topics.scans = nh_.resolveName("scans");  // registered scans, where the bag has them
    topics.scans_if_any = true;
  }
  std::string error;
  try {
    const BagSummary s = flexcloud::readBag(bag, topics, collector_, &cloud, [this](double) {
      GuardedLock lock(mutex_);
      if (bag_stop_) throw BagStopped{};
    });
    ROS_INFO("%s: read %zu fixes on %s and %zu poses on %s from %s", name_.c_str(), s.fixes,
             s.fix_topic.c_str(), s.poses, s.odom_topic.c_str(), bag.c_str());
    if (s.maps > 0) takeBagMap(cloud, s.map_topic);
  } catch (const BagStopped&) {
    return;
  } catch (const Error& e) {
    error = e.what();
    ROS_ERROR("%s: %s", name_.c_str(), error.c_str());
    publisher_->report(failed(error));
  }
  GuardedLock lock(mutex_);
  bag_done_ = true;
  bag_error_ = error;
  if (error.empty() && params_.georeference_on_bag_end && !busy_ && !service_job_) {
    service_job_ = Job{params_, nullptr, {}};
    wake_.notify_all();
  }
}

void GeoreferenceNode::takeBagMap(pcl::PCLPointCloud2& cloud, const std::string& topic) {
  sensor_msgs::PointCloud2Ptr msg(new sensor_msgs::PointCloud2);
  pcl_conversions::moveFromPCL(cloud, *msg);
  try {
    ros_conv::xyzLayout(*msg, "the bag's map on " + topic);
  } catch (const Error& e) {
    ROS_ERROR("%s: %s", name_.c_str(), e.what());
    GuardedLock lock(mutex_);
    map_error_ = e.what();
    return;
  }
  ROS_INFO("%s: took the map of %u points on %s from the bag", name_.c_str(),
           msg->width * msg->height, topic.c_str());
  GuardedLock lock(mutex_);
  map_ = msg;
  map_error_.clear();
}

std::string GeoreferenceNode::readMapFile(const std::string& file, std::uint64_t* points) {
  sensor_msgs::PointCloud2Ptr msg(new sensor_msgs::PointCloud2);
  try {
    pcl::PCLPointCloud2 cloud = readPcd(file);
    pcl_conversions::moveFromPCL(cloud, *msg);
    ros_conv::xyzLayout(*msg, file);
  } catch (const Error& e) {
    const std::string error = "map_file " + std::string(e.what());
    ROS_ERROR("%s: %s", name_.c_str(), error.c_str());
    GuardedLock lock(mutex_);
    map_error_ = error;
    return error;
  }
  if (points != nullptr) *points = static_cast<std::uint64_t>(msg->width) * msg->height;
  ROS_INFO("%s: loaded %u points from %s", name_.c_str(), msg->width * msg->height, file.c_str());
  GuardedLock lock(mutex_);
  map_ = msg;
  map_error_.clear();
  return "";
}

bool GeoreferenceNode::waitForJob(Job& job) {
  GuardedLock lock(mutex_);
  while (!stop_ && !service_job_ &&
         !(recompute_pending_ && std::chrono::steady_clock::now() >= recompute_at_)) {
    if (recompute_pending_) {
      lock.waitUntil(wake_, recompute_at_);
    } else {
      lock.wait(wake_);
    }
  }
  if (stop_) return false;
  if (service_job_) {
    job = std::move(*service_job_);
    service_job_.reset();
  } else {
    job = Job{params_, nullptr, {}};  // the latest setting wins
  }
  job.notes.insert(job.notes.end(), pending_notes_.begin(), pending_notes_.end());
  pending_notes_.clear();
  recompute_pending_ = false;
  busy_ = true;
  return true;
}

void GeoreferenceNode::workerLoop() {
  if (const std::string file = params().map_file; !file.empty()) readMapFile(file, nullptr);
  Job job;
  while (waitForJob(job)) {
    std::uint64_t generation;
    auto cancel = std::make_shared<CancelToken>();
    {
      GuardedLock lock(mutex_);
      generation = generation_;
      run_cancel_ = cancel;
    }
    std::shared_ptr<const NodeResult> result;
    std::string error;
    try {
      result = run(job, *cancel);
    } catch (const std::exception& e) {
      error = e.what();
    }
    const flexcloud::Result outcome = finish(result, error, generation);
    if (job.reply) job.reply->set_value(outcome);
  }
  GuardedLock lock(mutex_);
  if (service_job_ && service_job_->reply) {
    service_job_->reply->set_value(failed("the node is shutting down"));
  }
  service_job_.reset();
}

flexcloud::Result GeoreferenceNode::finish(std::shared_ptr<const NodeResult> result,
                                           const std::string& error, std::uint64_t generation) {
  GuardedLock lock(mutex_);
  busy_ = false;
  run_cancel_.reset();
  if (generation != generation_) {
    return failed("reset while the run was going: its result was dropped");
  }
  if (!error.empty()) {
    ROS_ERROR("%s: georeferencing failed: %s%s", name_.c_str(), error.c_str(),
              result_ ? " (the published result stays, made with the parameters it lists)" : "");
    const auto msg = toResultMsg(result_.get(), false, error);
    lock.unlock();
    publisher_->report(msg);
    return msg;
  }
  result_ = result;
  lock.unlock();
  const auto& r = result->result;
  std::string message =
      "georeferenced " + std::to_string(r.poses.size()) + " poses with " +
      std::to_string(r.control_points.points.size()) + " control points" +
      (result->map ? " and a map of " + std::to_string(result->map_info.warp.points) + " points"
                   : " (no map yet)");
  for (const auto& w : result->warnings) message += "; warning: " + w;
  publisher_->show(*result);
  const auto msg = toResultMsg(result.get(), true, message);
  publisher_->report(msg);
  ROS_INFO("%s: %s: MAE %.3f m to the GNSS (rigid only %.3f m)", name_.c_str(), message.c_str(),
           r.metrics_rubbersheet.mae, r.metrics_aligned.mae);
  for (const auto& w : result->warnings) ROS_WARN("%s: %s", name_.c_str(), w.c_str());
  return msg;
}

std::string GeoreferenceNode::leverArmFromTf(NodeParams& params) {
  if (!params.lever_arm_from_tf) return "parameters (lever_arm_from_tf is false)";
  const std::string body = params.body_frame.empty() ? collector_.bodyFrame() : params.body_frame;
  const std::string antenna = collector_.fixFrame();
  if (body.empty() || antenna.empty()) {
    return "parameters (the " + std::string(body.empty() ? "body" : "fixes'") +
           " frame id is empty, so TF cannot be asked)";
  }
  if (body == antenna) return "parameters (the fixes are in the body frame " + body + ")";
  try {
    const auto t = tf_buffer_.lookupTransform(body, antenna, ros::Time(0));
    params.core.lever_arm_x = t.transform.translation.x;
    params.core.lever_arm_y = t.transform.translation.y;
    params.core.lever_arm_z = t.transform.translation.z;
    return "tf " + body + " -> " + antenna;
  } catch (const tf2::TransformException& e) {
    char arm[96];
    std::snprintf(arm, sizeof(arm), "(%.3f, %.3f, %.3f) m", params.core.lever_arm_x,
                  params.core.lever_arm_y, params.core.lever_arm_z);
    const std::string why = "no TF from " + body + " to " + antenna + " (" + e.what() + ")";
    const bool unset = params.core.lever_arm_x == 0.0 && params.core.lever_arm_y == 0.0 &&
                       params.core.lever_arm_z == 0.0;
    if (unset && tf_told_ != body + " " + antenna) {
      tf_told_ = body + " " + antenna;
      ROS_INFO(
          "%s: no TF from %s to %s: the antenna is taken at the body's origin (publish the "
          "TF or set lever_arm_x/y/z if it is not)",
          name_.c_str(), body.c_str(), antenna.c_str());
    }
    return "parameters " + std::string(arm) + ": " + why;
  }
}

std::string GeoreferenceNode::nothingReceived(const std::string& what, const std::string& topic,
                                              const std::string& type) const {
  std::string message = "no " + what + " received yet on " + topic;
  ros::master::V_TopicInfo topics;
  if (!ros::master::getTopics(topics)) return message;
  std::string found;
  for (const auto& t : topics) {
    const bool own = t.name.rfind(name_ + "/", 0) == 0;  // e.g. ~origin, a NavSatFix too
    if (t.datatype == type && t.name != topic && !own) {
      found += (found.empty() ? "" : ", ") + t.name;
    }
  }
  message += found.empty() ? " (no " + type + " topic is published now)"
                           : " (" + type + " is published on " + found + ": remap to it)";
  return message;
}

std::shared_ptr<const NodeResult> GeoreferenceNode::run(const Job& job, const CancelToken& cancel) {
  NodeParams params = job.params;
  const auto t0 = std::chrono::steady_clock::now();
  auto s = std::make_shared<NodeResult>();
  s->lever_arm_source = leverArmFromTf(params);
  const DriveInput input = collector_.snapshot();
  if (input.fixes.empty()) {
    if (!params.bag.empty()) throw Error("no GNSS fix read from " + params.bag);
    throw Error(nothingReceived("GNSS fix", nh_.resolveName("fix"), "sensor_msgs/NavSatFix"));
  }
  if (input.poses.empty()) {
    if (!params.bag.empty()) throw Error("no pose read from " + params.bag);
    const std::string type = params.odom_type == "odometry" ? "nav_msgs/Odometry"
                             : params.odom_type == "pose"   ? "geometry_msgs/PoseStamped"
                                                            : "nav_msgs/Path";
    throw Error(nothingReceived("pose", nh_.resolveName("odom"), type));
  }
  s->result = flexcloud::georeference(input, params.core, cancel);
  cancel.check("georeferencing");
  s->params = params;
  s->frames.enu = params.enu_frame;
  s->frames.map = !params.map_frame.empty()        ? params.map_frame
                  : !collector_.mapFrame().empty() ? collector_.mapFrame()
                                                   : std::string("map");
  checkDegraded(s->result, params.core, nullptr, s->frames.map);  // before the map's warp
  s->map = warpMap(params, s->result, cancel, s->map_info);
  checkDegraded(s->result, params.core, s->map ? &s->map_info.warp : nullptr, s->frames.map);
  s->warnings = job.notes;
  const MapInfo* map = s->map ? &s->map_info : nullptr;
  for (auto& w : mapWarnings(s->result, params.core, map, s->frames.map)) {
    s->warnings.push_back(std::move(w));
  }
  s->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return s;
}

namespace {

/// A copy of `map` with its fields `fields` (withSigmaFields()): every point followed by room
/// for its sigma_h and sigma_v, which the warp writes there (point_sigma.h). One copy of the
/// map beside the original, as without the sigmas.
sensor_msgs::PointCloud2Ptr widenedForSigmas(const sensor_msgs::PointCloud2& map,
                                             const std::vector<pcl::PCLPointField>& fields) {
  sensor_msgs::PointCloud2Ptr wide(new sensor_msgs::PointCloud2);
  wide->header = map.header;
  wide->height = map.height;
  wide->width = map.width;
  pcl_conversions::fromPCL(fields, wide->fields);
  wide->is_bigendian = map.is_bigendian;
  wide->point_step = static_cast<std::uint32_t>(map.point_step + kPointSigmaBytes);
  wide->row_step = wide->point_step * wide->width;
  wide->is_dense = map.is_dense;
  wide->data.resize(static_cast<std::size_t>(wide->row_step) * wide->height);
  widenPoints(map.data.data(), map.point_step, static_cast<std::size_t>(map.width) * map.height,
              wide->data.data());
  return wide;
}

}  // namespace

sensor_msgs::PointCloud2ConstPtr GeoreferenceNode::scanMap(const GeoreferenceResult& r) const {
  DriveCollector::Scans scans = collector_.scans();
  if (!scans.cloud) return nullptr;
  const std::string poses = collector_.mapFrame();
  if (scansInBodyFrame(scans.frame, poses, collector_.bodyFrame(), nh_.resolveName("scans"))) {
    placeBodyScans(*scans.cloud, r.poses);  // as the LiDAR saw them: placed by the SLAM's poses
  }
  sensor_msgs::PointCloud2Ptr msg(new sensor_msgs::PointCloud2);
  pcl_conversions::moveFromPCL(*scans.cloud, *msg);
  msg->header.frame_id = poses.empty() ? "map" : poses;
  return msg;
}

sensor_msgs::PointCloud2ConstPtr GeoreferenceNode::warpMap(const NodeParams& params,
                                                           const GeoreferenceResult& r,
                                                           const CancelToken& cancel,
                                                           MapInfo& info) {
  bool reload = false;
  {
    GuardedLock lock(mutex_);
    reload = !map_error_.empty() && !params.map_file.empty();
  }
  // A map file that could not be read before is tried again: it may be there now.
  if (reload) {
    if (const std::string e = readMapFile(params.map_file, nullptr); !e.empty()) throw Error(e);
  }
  sensor_msgs::PointCloud2ConstPtr map;
  {
    GuardedLock lock(mutex_);
    map = map_;
  }
  std::string name = params.map_file.empty() ? nh_.resolveName("map") : params.map_file;
  std::string wanted = params.core.map_pose_field;
  if (params.map_file.empty()) {
    if (sensor_msgs::PointCloud2ConstPtr scans = scanMap(r)) {
      map = std::move(scans);
      name = nh_.resolveName("scans");
      wanted = kScanTimeField;
    }
  }
  if (!map) return nullptr;
  const auto t0 = std::chrono::steady_clock::now();
  info.input = name;
  // A map message whose data does not hold its points is named before any copy of it.
  XyzLayout layout = ros_conv::xyzLayout(*map, name);
  std::optional<PointSigmaField> field;
  SigmaSink sink;
  sensor_msgs::PointCloud2Ptr warped;
  if (params.core.point_sigma) {  // refused before the warp where the map holds them already
    warped =
        widenedForSigmas(*map, withSigmaFields(ros_conv::pclFields(*map), map->point_step, name));
    sink = {&field.emplace(r.rubbersheet, r.sigma, *r.sheet, pointSigmaModel(params.core)),
            warped->data.data() + map->point_step, warped->point_step};
    layout.point_step = warped->point_step;
  } else {
    warped.reset(new sensor_msgs::PointCloud2(*map));
  }
  const PoseCorrections corrections(r.poses, resultPoses(r), r.T_enu_map);
  const std::size_t points = static_cast<std::size_t>(map->width) * map->height;
  const MapMotion motion = mapMotion(
      ros_conv::pclFields(*map), wanted, corrections,
      [&](const PointPoseField& f) {
        return fieldValues(map->data.data(), map->point_step, points, f);
      },
      name);
  info.pose_field = motion.rebuild ? motion.rebuild->field.name : "";
  info.pose_field_note = motion.note;
  info.warp = motion.rebuild ? rebuildPoints(warped->data.data(), layout, *motion.rebuild,
                                             params.core.threads, name, cancel, sink)
                             : warpPoints(warped->data.data(), layout, *r.sheet,
                                          params.core.threads, name, cancel, sink);
  info.warp_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  warped->header.frame_id = params.enu_frame;
  warped->header.stamp = ros::Time::now();
  return warped;
}

flexcloud::Georeference::Response GeoreferenceNode::refused(const std::string& why) const {
  return toResponse(failed(why));
}

flexcloud::Georeference::Response GeoreferenceNode::georeference(int control_points,
                                                                 double stddev_threshold) {
  if (!startup_error_.empty()) return refused(startup_error_);
  auto reply = std::make_shared<std::promise<flexcloud::Result>>();
  auto future = reply->get_future();
  NodeParams params;
  std::string changed;  // the node's values the request changed: "name was -> now"
  {
    GuardedLock lock(mutex_);
    if (stop_) return refused("the node is shutting down");
    if (busy_ || service_job_) {
      return refused("a georeferencing run is going; call again when it has finished");
    }
    if (!bag_done_) return refused("still reading the bag " + params_.bag + "; call again soon");
    if (!bag_error_.empty()) {
      publisher_->report(failed(bag_error_));
      return refused(bag_error_);
    }
    params = params_;
    const auto override_with = [&](const char* name, double value) {
      if (value == 0.0) return std::string();  // 0 keeps the node's value
      const std::string bad = checkParam(name, ParamValue{value, "", {}});
      if (!bad.empty()) return bad;
      const std::string was = nodeParamTable().text(params, name);
      nodeParamTable().set(params, name, ParamValue{value, "", {}});
      const std::string now = nodeParamTable().text(params, name);
      if (now != was)
        changed += std::string(changed.empty() ? "" : ", ") + name + " " + was + " -> " + now;
      return std::string();
    };
    const std::string bad = override_with("control_points", control_points) +
                            override_with("stddev_threshold", stddev_threshold);
    if (!bad.empty()) return refused("request refused: " + bad);
    params_ = params;
    service_job_ = Job{params, reply, {}};
  }
  wake_.notify_all();
  pushConfig(params);
  if (!changed.empty()) {
    changed =
        "the request set " + changed + " (the node keeps them; dynamic_reconfigure shows them)";
    ROS_INFO_STREAM("flexcloud: " << changed);
  }
  flexcloud::Georeference::Response res = toResponse(future.get());
  if (!changed.empty()) res.message = changed + (res.message.empty() ? "" : "; ") + res.message;
  return res;
}

flexcloud::Save::Response GeoreferenceNode::save(const std::string& dir, bool autoware, bool las) {
  flexcloud::Save::Response res;
  if (!startup_error_.empty()) {
    res.message = startup_error_;
    return res;
  }
  std::shared_ptr<const NodeResult> s;
  {
    GuardedLock lock(mutex_);
    s = result_;
  }
  if (!s) {
    res.message = "no result to save: call georeference first (a reset withdraws the result)";
    return res;
  }
  if (dir.empty()) {
    res.message = "directory is empty";
    return res;
  }
  const std::string absolute = std::filesystem::absolute(dir).lexically_normal().string();
  MapWriter write_map;
  if (s->map) {
    write_map = [&](const std::string& path) {
      writePcdBinary(path, ros_conv::pclFields(*s->map), s->map->point_step, s->map->width,
                     s->map->height, s->map->data.data(), s->map->data.size());
    };
  }
  RunContext run;
  run.frames = s->frames;
  run.map = s->map ? &s->map_info : nullptr;
  run.plot_script = findPlotScript();
  Params params = s->params.core;
  params.autoware = params.autoware || autoware;
  params.las = params.las || las;
  const ExportSummary e = writeOutputs(absolute, s->result, params, write_map, run);
  res.success = true;
  res.message = "wrote the result into " + absolute;
  for (const auto& note : e.notes) res.message += "; " + note;
  return res;
}

std_srvs::Trigger::Response GeoreferenceNode::reset() {
  std_srvs::Trigger::Response res;
  if (!startup_error_.empty()) {
    res.message = startup_error_;
    return res;
  }
  FrameNames frames;
  {
    GuardedLock lock(mutex_);
    ++generation_;  // a run going now is dropped when it ends
    if (run_cancel_) run_cancel_->cancel();
    if (result_) frames = result_->frames;
    result_.reset();
    recompute_pending_ = false;
    bag_stop_ = true;
  }
  if (bag_thread_.joinable()) bag_thread_.join();
  const auto [fixes, poses] = collector_.clear();
  publisher_->withdraw(frames);
  publisher_->report(toResultMsg(nullptr, false, "reset: no result yet: call ~georeference"));
  const std::string bag = params().bag;
  if (!bag.empty()) startBagRead();
  res.success = true;
  res.message = "cleared " + std::to_string(fixes) + " fixes, " + std::to_string(poses) +
                " poses and the result" + (bag.empty() ? "" : "; reading " + bag + " again");
  ROS_INFO("%s: %s", name_.c_str(), res.message.c_str());
  return res;
}

flexcloud::LoadMap::Response GeoreferenceNode::loadMap(const std::string& file) {
  flexcloud::LoadMap::Response res;
  if (!startup_error_.empty()) {
    res.message = startup_error_;
    return res;
  }
  const std::string path = file.empty() ? params().map_file : file;
  if (path.empty()) {
    res.message = "no file given and no ~map_file set";
    return res;
  }
  res.message = readMapFile(path, &res.points);
  res.success = res.message.empty();
  if (!res.success) return res;
  bool published = false;
  {
    GuardedLock lock(mutex_);
    published = result_ != nullptr;
  }
  res.message =
      "loaded " + std::to_string(res.points) + " points from " + path +
      (published ? "; call ~georeference to warp it (the published map is the earlier one)"
                 : "; call ~georeference to warp it");
  return res;
}

void GeoreferenceNode::pushConfig(const NodeParams& p) {
  GeoreferenceConfig c;
  {
    boost::recursive_mutex::scoped_lock lock(config_mutex_);
    reconfigure_->getConfigDefault(c);
  }
  toConfig(p, c);
  reconfigure_->updateConfig(c);
}

void GeoreferenceNode::onReconfigure(GeoreferenceConfig& c, uint32_t /*level*/) {
  GuardedLock lock(mutex_);
  NodeParams p;
  std::string bad;
  try {
    p = fromConfig(c, params_);
    bad = p.validate();
  } catch (const Error& e) {
    bad = e.what();
  }
  if (!bad.empty()) {
    ROS_ERROR("%s: dynamic_reconfigure change refused: %s", name_.c_str(), bad.c_str());
    toConfig(params_, c);  // the server shows the values in use
    return;
  }
  const bool changed = !nodeParamTable().same(p, params_);
  for (auto& note : clampNotes(params_, p)) {
    ROS_WARN("%s: %s", name_.c_str(), note.c_str());
    pending_notes_.push_back(std::move(note));
  }
  params_ = p;
  if (changed && result_) {
    recompute_pending_ = true;
    recompute_at_ = std::chrono::steady_clock::now() +
                    std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                        std::chrono::duration<double>(params_.recompute_delay));
    wake_.notify_all();
  }
}

std::vector<std::string> GeoreferenceNode::clampNotes(const NodeParams& before,
                                                      const NodeParams& after) const {
  std::vector<std::string> notes;
  for (const auto& row : nodeParamTable().rows()) {
    const ParamSpec& spec = row.spec;
    if (!spec.live || (spec.type != ParamType::kReal && spec.type != ParamType::kInt)) continue;
    const double now = row.get(after).number;
    if (now == row.get(before).number || (now != spec.min && now != spec.max)) continue;
    notes.push_back(spec.name + " is " + formatValue(spec, row.get(after)) + ", the " +
                    (now == spec.min ? "least" : "largest") + " it can be in [" +
                    formatValue(spec, ParamValue{spec.min, "", {}}) + ", " +
                    formatValue(spec, ParamValue{spec.max, "", {}}) +
                    "] (dynamic_reconfigure sets a value asked beyond it to the bound)");
  }
  return notes;
}

}  // namespace flexcloud
