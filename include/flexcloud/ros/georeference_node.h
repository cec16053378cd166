#pragma once
// The ROS side of flexcloud, owned by the nodelet and by the standalone node alike: collects the
// drive (live topics or a bag, through one DriveCollector), runs the core pipeline on a worker
// thread when asked, publishes the result. No algorithm lives here.

#include <dynamic_reconfigure/server.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/static_transform_broadcaster.h>

#include <condition_variable>
#include <future>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include "flexcloud/Georeference.h"
#include "flexcloud/GeoreferenceConfig.h"
#include "flexcloud/Save.h"
#include "flexcloud/cloud_warp.h"
#include "flexcloud/io/outputs.h"
#include "flexcloud/ros/drive_collector.h"
#include "flexcloud/ros/node_params.h"

namespace flexcloud {

class GeoreferenceNode {
 public:
  /// Reads and checks the parameters (throws Error naming every bad value; nothing is started
  /// then), subscribes or starts reading ~bag, advertises, starts the worker. Never blocks.
  GeoreferenceNode(ros::NodeHandle nh, ros::NodeHandle pnh);
  ~GeoreferenceNode();
  GeoreferenceNode(const GeoreferenceNode&) = delete;
  GeoreferenceNode& operator=(const GeoreferenceNode&) = delete;

  /// Runs the pipeline on the worker and waits for it. Refused (success false) while another
  /// run is going or queued. control_points > 0 / stddev_threshold > 0 become the node's values.
  flexcloud::Georeference::Response georeference(int control_points, double stddev_threshold);
  /// Writes the latest result's files into `dir`.
  flexcloud::Save::Response save(const std::string& dir);
  /// Forgets every fix and pose collected so far.
  void reset();

 private:
  /// Everything one finished run produced.
  struct State {
    GeoreferenceResult result;
    Params params;
    FrameNames frames;
    sensor_msgs::PointCloud2ConstPtr map;  ///< warped, in the ENU frame; null without a map
    MapInfo map_info;
    double seconds = 0.0;
  };
  struct Job {
    Params params;
    std::shared_ptr<std::promise<flexcloud::Georeference::Response>> reply;  // null: recompute
  };

  void subscribe();
  void advertise();
  void onMap(const sensor_msgs::PointCloud2ConstPtr& msg);
  bool onGeoreference(flexcloud::Georeference::Request& req,
                      flexcloud::Georeference::Response& res);
  bool onSave(flexcloud::Save::Request& req, flexcloud::Save::Response& res);
  bool onReset(std_srvs::Trigger::Request& req, std_srvs::Trigger::Response& res);
  void onReconfigure(GeoreferenceConfig& config, uint32_t level);
  void pushConfig(const Params& p);

  void workerLoop();
  void readBagThread();
  void loadMapFile();
  std::shared_ptr<const State> run(const Params& params);
  void publish(const State& s);
  flexcloud::Georeference::Response describe(const State& s) const;

  // Declared first, destroyed last: the node handles and services below still reach it when
  // they go (a queue destroyed before them made the nodelet crash on unload).
  ros::CallbackQueue service_queue_;
  ros::NodeHandle nh_;
  ros::NodeHandle pnh_;
  ros::NodeHandle service_nh_;  // services on their own queue and spinner (see below)
  std::unique_ptr<ros::AsyncSpinner> service_spinner_;
  std::string name_;
  NodeParams params_;  // guarded by mutex_ once the worker runs; first for the initializers
  DriveCollector collector_;
  std::vector<ros::Subscriber> subscribers_;
  ros::Publisher map_pub_, origin_pub_, path_gnss_pub_, path_slam_pub_, path_aligned_pub_,
      path_sheet_pub_, cp_pub_, tet_pub_, dev_pub_;
  std::vector<ros::ServiceServer> services_;
  tf2_ros::StaticTransformBroadcaster tf_;

  boost::recursive_mutex config_mutex_;
  std::unique_ptr<dynamic_reconfigure::Server<GeoreferenceConfig>> reconfigure_;

  // Guarded by mutex_.
  std::mutex mutex_;
  std::condition_variable wake_;
  bool busy_ = false;
  bool stop_ = false;
  std::optional<Job> service_job_;
  bool recompute_pending_ = false;
  std::chrono::steady_clock::time_point recompute_at_;
  std::shared_ptr<const State> state_;
  sensor_msgs::PointCloud2ConstPtr map_;  ///< as received / loaded, map frame
  std::string map_error_;                 ///< why ~map_file could not be loaded
  bool bag_done_ = true;
  std::string bag_error_;

  std::thread worker_;
  std::thread bag_thread_;
};

}  // namespace flexcloud
