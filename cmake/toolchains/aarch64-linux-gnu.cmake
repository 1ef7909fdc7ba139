# Cross-compiling Kestrel for 64-bit ARM Linux (the on-board computer) with Debian's
# g++-aarch64-linux-gnu against an arm64 sysroot of Debian packages, and running what it builds
# (tests, gtest_discover_tests at build time, try_run) under qemu-aarch64 user-mode emulation.
# scripts/check_arm64.sh makes the sysroot, configures with this file, builds and tests
# (docs/onboard.md).
#
# The sysroot: KESTREL_ARM64_SYSROOT (a cache variable or the environment variable of the same
# name), by default build/arm64-sysroot of this checkout. It holds Debian's arm64 packages
# unpacked with `dpkg -x` (multiarch layout: usr/lib/aarch64-linux-gnu, usr/include/...).
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)

if(NOT KESTREL_ARM64_SYSROOT)
  if(DEFINED ENV{KESTREL_ARM64_SYSROOT} AND NOT "$ENV{KESTREL_ARM64_SYSROOT}" STREQUAL "")
    set(KESTREL_ARM64_SYSROOT "$ENV{KESTREL_ARM64_SYSROOT}")
  else()
    get_filename_component(KESTREL_ARM64_SYSROOT "${CMAKE_CURRENT_LIST_DIR}/../../build/arm64-sysroot"
                           ABSOLUTE)
  endif()
endif()
if(NOT EXISTS "${KESTREL_ARM64_SYSROOT}/usr/include/aarch64-linux-gnu")
  message(FATAL_ERROR "arm64 sysroot not found at ${KESTREL_ARM64_SYSROOT} (no "
                      "usr/include/aarch64-linux-gnu): run scripts/check_arm64.sh, which makes it, "
                      "or set KESTREL_ARM64_SYSROOT")
endif()
set(KESTREL_ARM64_SYSROOT "${KESTREL_ARM64_SYSROOT}" CACHE PATH "arm64 sysroot (Debian packages)")
# try_compile projects re-read this file without the cache: hand the sysroot on to them.
list(APPEND CMAKE_TRY_COMPILE_PLATFORM_VARIABLES KESTREL_ARM64_SYSROOT)

set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
set(CMAKE_SYSROOT "${KESTREL_ARM64_SYSROOT}")

# Headers, libraries and CMake package configs from the sysroot only; programs (pkg-config,
# protoc, ...) from the host.
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)

# The libraries' own dependencies (libopencv_imgcodecs -> libgdal -> ...) are found in the
# sysroot's multiarch folders when linking executables.
foreach(_dir lib/aarch64-linux-gnu usr/lib/aarch64-linux-gnu)
  string(APPEND CMAKE_EXE_LINKER_FLAGS_INIT " -Wl,-rpath-link,${KESTREL_ARM64_SYSROOT}/${_dir}")
  string(APPEND CMAKE_SHARED_LINKER_FLAGS_INIT " -Wl,-rpath-link,${KESTREL_ARM64_SYSROOT}/${_dir}")
endforeach()

# Running target programs: ctest, gtest_discover_tests (which lists a test executable's cases
# at build time) and try_run prefix this. -L: the ELF interpreter and shared libraries come
# from the sysroot.
find_program(KESTREL_QEMU_AARCH64 NAMES qemu-aarch64-static qemu-aarch64 NO_CMAKE_FIND_ROOT_PATH)
if(KESTREL_QEMU_AARCH64)
  set(CMAKE_CROSSCOMPILING_EMULATOR "${KESTREL_QEMU_AARCH64};-L;${KESTREL_ARM64_SYSROOT}")
else()
  message(WARNING "qemu-aarch64 not found (Debian: qemu-user-static): the arm64 tests cannot "
                  "run here, and test discovery at build time fails")
endif()
