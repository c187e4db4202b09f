# Cross-compiling for the vehicle's Jetson (arm64) with Debian's cross toolchain
# (g++-aarch64-linux-gnu). The arm64 -dev packages are not all multi-arch co-installable beside
# the amd64 ones, so scripts/cross-arm64 unpacks them (apt-get download + dpkg -x) into a sysroot
# folder given as KESTREL_ARM64_SYSROOT; libc comes from the toolchain itself.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
list(APPEND CMAKE_TRY_COMPILE_PLATFORM_VARIABLES KESTREL_ARM64_SYSROOT)
if(NOT KESTREL_ARM64_SYSROOT)
  message(FATAL_ERROR "set -DKESTREL_ARM64_SYSROOT=<folder made by scripts/cross-arm64>")
endif()
set(triple aarch64-linux-gnu)
set(CMAKE_FIND_ROOT_PATH ${KESTREL_ARM64_SYSROOT} /usr/${triple})
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)   # lcm-gen, java: the host's
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE BOTH)    # Eigen's config is architecture-independent
set(CMAKE_CXX_FLAGS_INIT "-isystem ${KESTREL_ARM64_SYSROOT}/usr/include -isystem ${KESTREL_ARM64_SYSROOT}/usr/include/${triple}")
set(CMAKE_C_FLAGS_INIT "${CMAKE_CXX_FLAGS_INIT}")
set(link_dirs "-L${KESTREL_ARM64_SYSROOT}/usr/lib/${triple} -L${KESTREL_ARM64_SYSROOT}/lib/${triple} -Wl,-rpath-link,${KESTREL_ARM64_SYSROOT}/usr/lib/${triple} -Wl,-rpath-link,${KESTREL_ARM64_SYSROOT}/lib/${triple}")
set(CMAKE_EXE_LINKER_FLAGS_INIT "${link_dirs}")
set(CMAKE_SHARED_LINKER_FLAGS_INIT "${link_dirs}")
set(ENV{PKG_CONFIG_LIBDIR} "${KESTREL_ARM64_SYSROOT}/usr/lib/${triple}/pkgconfig:${KESTREL_ARM64_SYSROOT}/usr/share/pkgconfig")
set(ENV{PKG_CONFIG_SYSROOT_DIR} "${KESTREL_ARM64_SYSROOT}")
set(Eigen3_DIR /usr/share/eigen3/cmake CACHE PATH "host Eigen (headers only)")
# Tests built here run under qemu-user (binfmt is not needed: the runner calls qemu directly).
set(CMAKE_CROSSCOMPILING_EMULATOR qemu-aarch64-static -L ${KESTREL_ARM64_SYSROOT})
