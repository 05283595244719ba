# Finds Debian's ROS 1 rosbag_storage (librosbag-storage-dev) and the message headers the bag code uses
# (libroscpp-core-dev, libstd-msgs-dev, libsensor-msgs-dev, libnav-msgs-dev, libgeometry-msgs-dev, libtf2-msgs-dev).
#
# Header and library by header and library, not through rosbag_storage's catkin config: that one loads pluginlib's
# ament config, which runs a Python helper needing ament_package and fails under any python3 but Debian's, and its
# pkg-config file requires a pluginlib.pc that Debian does not ship.
#
# Defines RosbagStorage_FOUND (RosbagStorage_MISSING: what was not found) and the imported target
# RosbagStorage::RosbagStorage; an imported target's include directories are SYSTEM, so ROS headers do not meet
# -Wshadow -Wpedantic -Werror.

set(_rosbag_header_dirs)
set(_rosbag_missing)
foreach(_item
    "rosbag/bag.h|"
    "ros/serialization.h|"
    "pluginlib/class_loader.hpp|pluginlib"
    "class_loader/class_loader.hpp|class_loader"
    "rcutils/types.h|rcutils"
    "rcpputils/shared_library.hpp|rcpputils"
    "ament_index_cpp/get_package_prefix.hpp|ament_index_cpp"
    "console_bridge/console.h|"
    "std_msgs/Header.h|"
    "sensor_msgs/PointCloud2.h|"
    "sensor_msgs/Imu.h|"
    "nav_msgs/Odometry.h|"
    "geometry_msgs/PoseStamped.h|"
    "tf2_msgs/TFMessage.h|")
  string(REPLACE "|" ";" _parts "${_item}")
  list(GET _parts 0 _header)
  list(LENGTH _parts _n)
  set(_suffix "")
  if(_n GREATER 1)
    list(GET _parts 1 _suffix)
  endif()
  string(MAKE_C_IDENTIFIER "${_header}" _var)
  find_path(ROSBAG_DIR_${_var} "${_header}" PATH_SUFFIXES ${_suffix})
  mark_as_advanced(ROSBAG_DIR_${_var})
  if(ROSBAG_DIR_${_var})
    list(APPEND _rosbag_header_dirs "${ROSBAG_DIR_${_var}}")
  else()
    list(APPEND _rosbag_missing "${_header}")
  endif()
endforeach()
list(REMOVE_DUPLICATES _rosbag_header_dirs)
# The compiler's own directories (/usr/include) must not come back as -isystem: that breaks libstdc++'s
# #include_next <stdlib.h>.
list(REMOVE_ITEM _rosbag_header_dirs /usr/include ${CMAKE_CXX_IMPLICIT_INCLUDE_DIRECTORIES})

set(_rosbag_libraries)
foreach(_lib rosbag_storage roscpp_serialization rostime cpp_common console_bridge)
  find_library(ROSBAG_LIB_${_lib} ${_lib})
  mark_as_advanced(ROSBAG_LIB_${_lib})
  if(ROSBAG_LIB_${_lib})
    list(APPEND _rosbag_libraries "${ROSBAG_LIB_${_lib}}")
  else()
    list(APPEND _rosbag_missing "lib${_lib}")
  endif()
endforeach()

if(_rosbag_missing)
  set(RosbagStorage_FOUND FALSE)
  set(RosbagStorage_MISSING "${_rosbag_missing}")
else()
  set(RosbagStorage_FOUND TRUE)
  if(NOT TARGET RosbagStorage::RosbagStorage)
    add_library(RosbagStorage::RosbagStorage INTERFACE IMPORTED)
    set_target_properties(RosbagStorage::RosbagStorage PROPERTIES
      INTERFACE_INCLUDE_DIRECTORIES "${_rosbag_header_dirs}"
      INTERFACE_LINK_LIBRARIES "${_rosbag_libraries}")
  endif()
endif()
