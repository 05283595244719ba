# Debian packages through CPack (cpack -G DEB in a build folder; tools/test_package.sh builds and checks them):
#   tsdf-mcl         the tsdf-mcl program (component cli)
#   libtsdf-mcl-dev  the static layer libraries, headers, CMake package and pkg-config file (component library)
#   tsdf-mcl-ros     the ROS 1 node, its launch files and configuration (component ros; where the node is built)
# for the architecture the build targets (amd64, or arm64 from cmake --preset arm64). Native builds take their
# shared-library Depends from dpkg-shlibdeps; cross builds cannot (the arm64 libraries are in a sysroot, not in
# dpkg's database), so they name Debian 12's runtime packages of what the program links.
# The components are set by the top-level CMakeLists.txt through CMAKE_INSTALL_DEFAULT_COMPONENT_NAME.

if(CMAKE_SYSTEM_PROCESSOR MATCHES "^(aarch64|arm64)$")
  set(TSDF_MCL_DEB_ARCH arm64)
elseif(CMAKE_SYSTEM_PROCESSOR MATCHES "^(x86_64|AMD64|amd64)$")
  set(TSDF_MCL_DEB_ARCH amd64)
else()
  set(TSDF_MCL_DEB_ARCH "${CMAKE_SYSTEM_PROCESSOR}")
endif()

set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME tsdf-mcl)
set(CPACK_PACKAGE_VENDOR "tsdf-mcl")
set(CPACK_PACKAGE_CONTACT "tsdf-mcl maintainers <tsdf-mcl@localhost>")
set(CPACK_PACKAGE_VERSION "${PROJECT_VERSION}")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "6-DoF Monte Carlo localization of a LiDAR in a TSDF map (Vulkan + CPU)")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_ARCHITECTURE "${TSDF_MCL_DEB_ARCH}")
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)

set(CPACK_COMPONENTS_ALL cli library)
if(TSDF_MCL_HAVE_ROS_NODE)
  list(APPEND CPACK_COMPONENTS_ALL ros)
endif()

set(CPACK_DEBIAN_CLI_PACKAGE_NAME tsdf-mcl)
set(CPACK_COMPONENT_CLI_DESCRIPTION "tsdf-mcl command-line program: build-map, localize, bench, simulate, render")
# A Vulkan driver to run on (lavapipe, or the GPU vendor's); without one `--backend auto` falls back to the CPU.
set(CPACK_DEBIAN_CLI_PACKAGE_RECOMMENDS "mesa-vulkan-drivers | vulkan-icd")

set(CPACK_DEBIAN_LIBRARY_PACKAGE_NAME libtsdf-mcl-dev)
set(CPACK_DEBIAN_LIBRARY_PACKAGE_SECTION libdevel)
set(CPACK_COMPONENT_LIBRARY_DESCRIPTION "tsdf-mcl static libraries, headers, CMake package and pkg-config file")
# Static libraries: the consumer links what they were built against (tsdf_mclConfig.cmake finds these).
set(_dev_depends "libeigen3-dev, libembree-dev, nlohmann-json3-dev, libnanoflann-dev, zlib1g-dev, libhdf5-dev,"
                 " libcairo2-dev, pkg-config, libsqlite3-dev, libzstd-dev, liblz4-dev, libyaml-cpp-dev")
if(TSDF_MCL_VULKAN)
  string(APPEND _dev_depends ", libvulkan-dev, libglm-dev")
endif()
if(TSDF_MCL_HAVE_ROSBAG)
  string(APPEND _dev_depends ", librosbag-storage-dev")
endif()
string(CONCAT CPACK_DEBIAN_LIBRARY_PACKAGE_DEPENDS ${_dev_depends})

set(CPACK_DEBIAN_ROS_PACKAGE_NAME tsdf-mcl-ros)
set(CPACK_COMPONENT_ROS_DESCRIPTION "tsdf-mcl ROS 1 node (tsdf_mcl_node), launch files and configuration")
set(CPACK_DEBIAN_ROS_PACKAGE_RECOMMENDS "mesa-vulkan-drivers | vulkan-icd, rosout, python3-roslaunch")

if(CMAKE_CROSSCOMPILING)
  set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS OFF)
  # What tools/tsdf-mcl links on Debian 12 (readelf -d NEEDED), by package; its newest symbol versions are
  # GLIBC_2.35 and GLIBCXX_3.4.29 (objdump -T), which Ubuntu 22.04 (JetPack 6) also has.
  string(CONCAT CPACK_DEBIAN_CLI_PACKAGE_DEPENDS
         "libc6 (>= 2.35), libstdc++6 (>= 11), libgcc-s1, libgomp1, libembree3-3, libcairo2, libyaml-cpp0.7, libhdf5-103-1,"
         " zlib1g, libsqlite3-0, libzstd1, liblz4-1")
  if(TSDF_MCL_VULKAN)
    string(APPEND CPACK_DEBIAN_CLI_PACKAGE_DEPENDS ", libvulkan1")
  endif()
else()
  set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
endif()

include(CPack)
