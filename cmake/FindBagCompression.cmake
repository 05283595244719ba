# Finds Debian's libzstd and liblz4 (libzstd-dev, liblz4-dev), which the rosbag2 reader decompresses MCAP chunks and
# rosbag2's compressed messages with: header and library each, without pkg-config, so that a consumer of the
# installed package finds them where pkg-config is not wanted (tests/install/check_install.sh).
#
# Defines BagCompression_FOUND and the imported targets BagCompression::zstd and BagCompression::lz4.

find_path(BagCompression_ZSTD_INCLUDE_DIR zstd.h)
find_library(BagCompression_ZSTD_LIBRARY zstd)
find_path(BagCompression_LZ4_INCLUDE_DIR lz4frame.h)
find_library(BagCompression_LZ4_LIBRARY lz4)
mark_as_advanced(BagCompression_ZSTD_INCLUDE_DIR BagCompression_ZSTD_LIBRARY BagCompression_LZ4_INCLUDE_DIR
                 BagCompression_LZ4_LIBRARY)

include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(BagCompression REQUIRED_VARS BagCompression_ZSTD_LIBRARY
                                  BagCompression_ZSTD_INCLUDE_DIR BagCompression_LZ4_LIBRARY
                                  BagCompression_LZ4_INCLUDE_DIR)

if(BagCompression_FOUND)
  foreach(_bag_lib zstd lz4)
    string(TOUPPER "${_bag_lib}" _bag_upper)
    if(NOT TARGET BagCompression::${_bag_lib})
      add_library(BagCompression::${_bag_lib} UNKNOWN IMPORTED)
      set_target_properties(BagCompression::${_bag_lib} PROPERTIES
                            IMPORTED_LOCATION "${BagCompression_${_bag_upper}_LIBRARY}"
                            INTERFACE_INCLUDE_DIRECTORIES "${BagCompression_${_bag_upper}_INCLUDE_DIR}")
    endif()
  endforeach()
endif()
