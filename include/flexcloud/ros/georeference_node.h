#pragma once
// The ROS side of flexcloud, owned by the nodelet and by the standalone node alike: collects the
// drive (live topics or a bag, through one DriveCollector), runs the core pipeline on a worker
// thread when asked, shows the result (result_publisher.h). No algorithm lives here.

#include <dynamic_reconfigure/server.h>
#include <pcl/PCLPointCloud2.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <condition_variable>
#include <future>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include "flexcloud/Georeference.h"
#include "flexcloud/GeoreferenceConfig.h"
#include "flexcloud/LoadMap.h"
#include "flexcloud/Save.h"
#include "flexcloud/cancel.h"
#include "flexcloud/ros/drive_collector.h"
#include "flexcloud/ros/guarded_mutex.h"
#include "flexcloud/ros/node_params.h"
#include "flexcloud/ros/result_publisher.h"

namespace flexcloud {

class GeoreferenceNode {
 public:
  /// Reads and checks the parameters, subscribes or starts reading ~bag, advertises, starts the
  /// worker. Never blocks and never throws for bad parameters: it logs the fatal line and
  /// answers every service with the reason instead (see startupError()).
  GeoreferenceNode(ros::NodeHandle nh, ros::NodeHandle pnh);
  ~GeoreferenceNode();
  GeoreferenceNode(const GeoreferenceNode&) = delete;
  GeoreferenceNode& operator=(const GeoreferenceNode&) = delete;

  /// Why the node did not start (bad parameters); empty when it runs.
  const std::string& startupError() const { return startup_error_; }

  /// Runs the pipeline on the worker and waits for it. Refused (success false) while another
  /// run is going or queued. control_points > 0 / stddev_threshold > 0 become the node's values
  /// after the same range check as dynamic_reconfigure's.
  flexcloud::Georeference::Response georeference(int control_points, double stddev_threshold);
  /// Writes the published result's files into `dir` (relative: to the working folder).
  /// autoware, las: write those too, whatever the parameters say.
  flexcloud::Save::Response save(const std::string& dir, bool autoware = false, bool las = false);
  /// Forgets every fix and pose collected so far and withdraws the result; in bag mode the bag
  /// is read again.
  std_srvs::Trigger::Response reset();
  /// Loads the map to warp from `file` (empty: ~map_file).
  flexcloud::LoadMap::Response loadMap(const std::string& file);

 private:
  struct Job {
    NodeParams params;
    std::shared_ptr<std::promise<flexcloud::Result>> reply;  // null: recompute or bag end
    std::vector<std::string> notes;  // for the result's warnings (values clamped on the way)
  };

  void start();
  /// A copy of the node's parameters, taken under the lock (dynamic_reconfigure and
  /// ~georeference assign them from other threads).
  NodeParams params() const;
  void advertiseServices();
  void advertiseFrameServices();
  /// The published result; throws Error when there is none (or the node did not start).
  std::shared_ptr<const NodeResult> latestResult();
  void subscribe(const NodeParams& p);
  void startBagRead();
  void onMap(const sensor_msgs::PointCloud2ConstPtr& msg);
  /// A registered scan into the collector's scan map (a scan of other fields is logged).
  void onScan(const sensor_msgs::PointCloud2& msg, const std::string& topic);
  void onReconfigure(GeoreferenceConfig& config, uint32_t level);
  void pushConfig(const NodeParams& p);

  void workerLoop();
  bool waitForJob(Job& job);
  void readBag();
  /// The map the bag held on `topic` becomes the node's map (as a map file's would).
  void takeBagMap(pcl::PCLPointCloud2& cloud, const std::string& topic);
  /// Loads `file` into map_; returns the error ("" on success) and the point count.
  std::string readMapFile(const std::string& file, std::uint64_t* points);
  std::shared_ptr<const NodeResult> run(const Job& job, const CancelToken& cancel);
  /// The lever arm from TF (body frame -> the fixes' frame) into `params`, when asked and there;
  /// returns where the lever arm came from. A TF asked for and not found is logged once per
  /// pair of frames, and only where the lever arm parameters are 0 (else they apply as set).
  std::string leverArmFromTf(NodeParams& params);
  /// "no GNSS fix received yet on TOPIC", with the topics of that type that exist now.
  std::string nothingReceived(const std::string& what, const std::string& topic,
                              const std::string& type) const;
  /// Lines on live values that landed on their range's bound (dynamic_reconfigure clamps
  /// values beyond it without a word).
  std::vector<std::string> clampNotes(const NodeParams& before, const NodeParams& after) const;
  /// The map the scans collected so far make (scan_map.h), in the poses' frame; null without
  /// scans. Throws Error for scans in neither the poses' frame nor their body's.
  sensor_msgs::PointCloud2ConstPtr scanMap(const GeoreferenceResult& r) const;
  sensor_msgs::PointCloud2ConstPtr warpMap(const NodeParams& params, const GeoreferenceResult& r,
                                           const CancelToken& cancel, MapInfo& info);
  /// Shows a finished run (or its failure) unless a reset came in between.
  flexcloud::Result finish(std::shared_ptr<const NodeResult> result, const std::string& error,
                           std::uint64_t generation);
  flexcloud::Georeference::Response refused(const std::string& why) const;

  // Declared first, destroyed last: the node handles and services below still reach it when
  // they go (a queue destroyed before them made the nodelet crash on unload).
  ros::CallbackQueue service_queue_;
  ros::NodeHandle nh_;
  ros::NodeHandle pnh_;
  ros::NodeHandle service_nh_;  // services on their own queue and spinner (see start())
  std::unique_ptr<ros::AsyncSpinner> service_spinner_;
  std::string name_;
  std::string startup_error_;
  DriveCollector collector_;
  std::vector<ros::Subscriber> subscribers_;
  std::vector<ros::ServiceServer> services_;
  std::unique_ptr<ResultPublisher> publisher_;
  tf2_ros::Buffer tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;

  boost::recursive_mutex config_mutex_;
  std::unique_ptr<dynamic_reconfigure::Server<GeoreferenceConfig>> reconfigure_;

  // Guarded by mutex_ (clang checks it: guarded_mutex.h).
  mutable GuardedMutex mutex_;
  std::condition_variable wake_;
  NodeParams params_ FLEXCLOUD_GUARDED_BY(mutex_);  ///< read through params() outside mutex_
  bool busy_ FLEXCLOUD_GUARDED_BY(mutex_) = false;
  bool stop_ FLEXCLOUD_GUARDED_BY(mutex_) = false;
  std::optional<Job> service_job_ FLEXCLOUD_GUARDED_BY(mutex_);
  bool recompute_pending_ FLEXCLOUD_GUARDED_BY(mutex_) = false;
  /// Clamp notes for the next run.
  std::vector<std::string> pending_notes_ FLEXCLOUD_GUARDED_BY(mutex_);
  std::chrono::steady_clock::time_point recompute_at_ FLEXCLOUD_GUARDED_BY(mutex_);
  /// The published result; null: none.
  std::shared_ptr<const NodeResult> result_ FLEXCLOUD_GUARDED_BY(mutex_);
  std::uint64_t generation_ FLEXCLOUD_GUARDED_BY(mutex_) = 0;  ///< raised by every reset
  /// Of the run going, if any.
  std::shared_ptr<CancelToken> run_cancel_ FLEXCLOUD_GUARDED_BY(mutex_);
  sensor_msgs::PointCloud2ConstPtr map_ FLEXCLOUD_GUARDED_BY(mutex_);  ///< map frame
  std::string map_error_ FLEXCLOUD_GUARDED_BY(mutex_);  ///< why the map file could not be read
  bool bag_done_ FLEXCLOUD_GUARDED_BY(mutex_) = true;
  /// The frames whose missing TF was logged (the worker thread's only).
  std::string tf_told_;
  bool bag_stop_ FLEXCLOUD_GUARDED_BY(mutex_) = false;
  std::string bag_error_ FLEXCLOUD_GUARDED_BY(mutex_);

  std::thread worker_;
  std::thread bag_thread_;
};

}  // namespace flexcloud
