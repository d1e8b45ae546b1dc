# Cross build for arm64 (aarch64) on a Debian 12 amd64 host (docs/install.md, "arm64 (cross
# build)"):
#   scripts/setup.sh --arch arm64     # host tools, the sysroot, configures and builds build-arm64/
# or by hand, once the sysroot exists (scripts/arm64_sysroot.sh):
#   cmake -S . -B build-arm64 -G Ninja -DCMAKE_TOOLCHAIN_FILE=cmake/toolchain-arm64.cmake
#
# Compiler: Debian's cross GCC 12 (crossbuild-essential-arm64), the same GCC as the amd64 build.
# Libraries and headers: the arm64 sysroot of Debian 12 packages that scripts/arm64_sysroot.sh
# unpacks (default ~/.cache/ndsid/sysroot-arm64; NDSID_ARM64_SYSROOT in the environment or the
# cache moves it). Programs the build runs (lcm-gen, javac, python3) are the host's.
# Programs built here run under qemu-user: binfmt_misc is not needed, CTest and
# gtest_discover_tests call `qemu-aarch64-static -L <sysroot> <program>` (the emulator below).
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)

if(NOT NDSID_ARM64_SYSROOT)
  if(DEFINED ENV{NDSID_ARM64_SYSROOT})
    set(NDSID_ARM64_SYSROOT "$ENV{NDSID_ARM64_SYSROOT}")
  elseif(DEFINED ENV{XDG_CACHE_HOME})
    set(NDSID_ARM64_SYSROOT "$ENV{XDG_CACHE_HOME}/ndsid/sysroot-arm64")
  else()
    set(NDSID_ARM64_SYSROOT "$ENV{HOME}/.cache/ndsid/sysroot-arm64")
  endif()
endif()
if(NOT EXISTS "${NDSID_ARM64_SYSROOT}/usr/include/aarch64-linux-gnu")
  message(FATAL_ERROR "arm64 sysroot missing at ${NDSID_ARM64_SYSROOT}: run scripts/arm64_sysroot.sh "
                      "(or scripts/setup.sh --arch arm64)")
endif()
set(NDSID_ARM64_SYSROOT "${NDSID_ARM64_SYSROOT}" CACHE PATH "arm64 sysroot (scripts/arm64_sysroot.sh)")
# try_compile projects read this file again: hand them the same sysroot.
list(APPEND CMAKE_TRY_COMPILE_PLATFORM_VARIABLES NDSID_ARM64_SYSROOT)

set(CMAKE_SYSROOT "${NDSID_ARM64_SYSROOT}")
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)

# Headers, libraries and CMake packages only from the sysroot; programs only from the host.
set(CMAKE_FIND_ROOT_PATH "${NDSID_ARM64_SYSROOT}")
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)

# pkg-config (LCM, libsystemd): the sysroot's .pc files, paths prefixed with the sysroot.
set(ENV{PKG_CONFIG_SYSROOT_DIR} "${NDSID_ARM64_SYSROOT}")
set(ENV{PKG_CONFIG_LIBDIR}
    "${NDSID_ARM64_SYSROOT}/usr/lib/aarch64-linux-gnu/pkgconfig:${NDSID_ARM64_SYSROOT}/usr/share/pkgconfig")
set(ENV{PKG_CONFIG_PATH} "")

# lcm-gen is a host program: the sysroot has no liblcm-bin, and find_program looks on the host.
# The Python module (pybind11) is not built: the sysroot has neither pybind11 nor python3-dev.
set(CMAKE_DISABLE_FIND_PACKAGE_pybind11 ON)

find_program(NDSID_QEMU_AARCH64 qemu-aarch64-static)
if(NDSID_QEMU_AARCH64)
  set(CMAKE_CROSSCOMPILING_EMULATOR "${NDSID_QEMU_AARCH64};-L;${NDSID_ARM64_SYSROOT}")
endif()
