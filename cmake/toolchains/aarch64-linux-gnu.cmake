# Cross build for aarch64 (Jetson, arm64 servers) with Debian's g++-aarch64-linux-gnu against the arm64 sysroot
# that tools/arm64_sysroot.sh unpacks (tools/setup.sh --arm64 makes both): everything is built for aarch64 except
# the shaders, which the host's glslc compiles (SPIR-V does not depend on the CPU). Binaries run here under
# qemu-aarch64 (CMAKE_CROSSCOMPILING_EMULATOR; tools/test_arm64.sh). Used by `cmake --preset arm64`.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)

if(DEFINED ENV{TSDF_MCL_ARM64_SYSROOT})
  set(TSDF_MCL_ARM64_SYSROOT "$ENV{TSDF_MCL_ARM64_SYSROOT}")
elseif(NOT TSDF_MCL_ARM64_SYSROOT)
  set(TSDF_MCL_ARM64_SYSROOT /opt/tsdf-mcl/arm64-sysroot)
endif()
if(NOT EXISTS "${TSDF_MCL_ARM64_SYSROOT}/usr/lib/aarch64-linux-gnu/libc.so")
  message(FATAL_ERROR "no arm64 sysroot at ${TSDF_MCL_ARM64_SYSROOT}: run tools/setup.sh --arm64 "
                      "(or set TSDF_MCL_ARM64_SYSROOT)")
endif()
# Try-compiles configure their own projects: pass the sysroot on to them.
list(APPEND CMAKE_TRY_COMPILE_PLATFORM_VARIABLES TSDF_MCL_ARM64_SYSROOT)

set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
set(CMAKE_SYSROOT "${TSDF_MCL_ARM64_SYSROOT}")
set(CMAKE_FIND_ROOT_PATH "${TSDF_MCL_ARM64_SYSROOT}")
# Programs (glslc, pkg-config) from the host; libraries, headers and CMake packages only from the sysroot.
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)

# pkg-config (Cairo) reads the sysroot's .pc files and prefixes their paths with it.
set(ENV{PKG_CONFIG_SYSROOT_DIR} "${TSDF_MCL_ARM64_SYSROOT}")
set(ENV{PKG_CONFIG_LIBDIR}
    "${TSDF_MCL_ARM64_SYSROOT}/usr/lib/aarch64-linux-gnu/pkgconfig:${TSDF_MCL_ARM64_SYSROOT}/usr/share/pkgconfig")
# FindHDF5 asks the host's h5cc (Debian's libhdf5-dev) for flags: its include folder is found again in the sysroot,
# its library folder is the x86-64 one, so name the sysroot's serial HDF5 library.
set(HDF5_C_LIBRARY_hdf5 "${TSDF_MCL_ARM64_SYSROOT}/usr/lib/aarch64-linux-gnu/hdf5/serial/libhdf5.so"
    CACHE FILEPATH "arm64 HDF5 library")

# gtest_discover_tests and any add_test run the aarch64 binaries through qemu-user with the sysroot's loader.
find_program(TSDF_MCL_QEMU_AARCH64 qemu-aarch64)
if(TSDF_MCL_QEMU_AARCH64)
  set(CMAKE_CROSSCOMPILING_EMULATOR "${TSDF_MCL_QEMU_AARCH64};-L;${TSDF_MCL_ARM64_SYSROOT}")
endif()
