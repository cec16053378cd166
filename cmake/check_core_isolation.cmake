# Fails the build when a translation unit of the core library included a ROS header (or our own
# ROS layer). Reads the compiler's dependency files of the target: run with
#   cmake -DDEP_DIR=<target's CMakeFiles dir> -P check_core_isolation.cmake
file(GLOB_RECURSE depfiles "${DEP_DIR}/*.o.d")
if(NOT depfiles)
  message(FATAL_ERROR "core isolation check: no dependency files under ${DEP_DIR}")
endif()
set(ros_roots "ros|roscpp|rosbag|rosbag_storage|rosconsole|roslib|rostime|std_msgs|std_srvs|sensor_msgs|nav_msgs|geometry_msgs|visualization_msgs|tf2|tf2_ros|tf2_msgs|tf2_eigen|nodelet|pluginlib|class_loader|dynamic_reconfigure|pcl_conversions|pcl_ros|message_filters|xmlrpcpp|actionlib|flexcloud/ros")
foreach(f ${depfiles})
  file(READ "${f}" deps)
  string(REGEX MATCH "/include/(${ros_roots})/[^ \\\n]+" hit "${deps}")
  if(hit)
    message(FATAL_ERROR "the core library must not see ROS: ${f} depends on ${hit}")
  endif()
endforeach()
