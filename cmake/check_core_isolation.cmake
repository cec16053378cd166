# Fails the build when a translation unit of the core library included a ROS header (or our own
# ROS layer), or, unless ALLOW_IO is set (the io library), an io header: flexcloud's own io
# headers and sources, PCL, yaml-cpp, PROJ. Reads the compiler's dependency files of the target
# (*.o.d, which CMake writes from 3.20 on; *.d, which -MD writes beside the objects before):
#   cmake -DDEP_DIR=<target's CMakeFiles dir> [-DALLOW_IO=ON] -P check_core_isolation.cmake
file(GLOB_RECURSE depfiles "${DEP_DIR}/*.o.d" "${DEP_DIR}/*.cpp.d")
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
  if(NOT ALLOW_IO)
    string(REGEX MATCH "(/include/flexcloud/io/|/src/io/|/pcl-[0-9.]+/|/yaml-cpp/|/include/proj)[^ \\\n]*" io_hit "${deps}")
    if(io_hit)
      message(FATAL_ERROR "the core library must not see io: ${f} depends on ${io_hit}")
    endif()
  endif()
endforeach()
