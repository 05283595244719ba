# Finds what the ROS 1 node (ros/) builds on, from Debian 12's packages: roscpp, tf2_ros and the message headers
# (libroscpp-dev, libtf2-ros-dev, libsensor-msgs-dev, libnav-msgs-dev, libgeometry-msgs-dev, libstd-srvs-dev,
# libdiagnostic-msgs-dev). Header and library by header and library, for the reasons FindRosbagStorage.cmake
# gives (no catkin environment is needed).
#
# Defines RosNode_FOUND (RosNode_MISSING: what was not found) and the imported target RosNode::RosNode.

set(_rosnode_missing)
set(_rosnode_header_dirs)
foreach(_header ros/ros.h tf2_ros/transform_broadcaster.h tf2_ros/transform_listener.h sensor_msgs/PointCloud2.h
                sensor_msgs/Imu.h nav_msgs/Odometry.h geometry_msgs/PoseWithCovarianceStamped.h
                geometry_msgs/PoseArray.h std_srvs/Empty.h diagnostic_msgs/DiagnosticArray.h)
  string(MAKE_C_IDENTIFIER "${_header}" _var)
  find_path(ROSNODE_DIR_${_var} "${_header}")
  mark_as_advanced(ROSNODE_DIR_${_var})
  if(ROSNODE_DIR_${_var})
    list(APPEND _rosnode_header_dirs "${ROSNODE_DIR_${_var}}")
  else()
    list(APPEND _rosnode_missing "${_header}")
  endif()
endforeach()
list(REMOVE_DUPLICATES _rosnode_header_dirs)
list(REMOVE_ITEM _rosnode_header_dirs /usr/include ${CMAKE_CXX_IMPLICIT_INCLUDE_DIRECTORIES})

set(_rosnode_libraries)
foreach(_lib tf2_ros tf2 actionlib message_filters roscpp rosconsole roscpp_serialization xmlrpcpp rostime
             cpp_common console_bridge boost_system boost_thread)
  find_library(ROSNODE_LIB_${_lib} ${_lib})
  mark_as_advanced(ROSNODE_LIB_${_lib})
  if(ROSNODE_LIB_${_lib})
    list(APPEND _rosnode_libraries "${ROSNODE_LIB_${_lib}}")
  else()
    list(APPEND _rosnode_missing "lib${_lib}")
  endif()
endforeach()

if(_rosnode_missing)
  set(RosNode_FOUND FALSE)
  set(RosNode_MISSING "${_rosnode_missing}")
else()
  set(RosNode_FOUND TRUE)
  if(NOT TARGET RosNode::RosNode)
    add_library(RosNode::RosNode INTERFACE IMPORTED)
    set_target_properties(RosNode::RosNode PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${_rosnode_header_dirs}"
                                                      INTERFACE_LINK_LIBRARIES "${_rosnode_libraries}")
  endif()
endif()
