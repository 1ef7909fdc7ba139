# `cpack -G DEB` in build/<preset>: one Debian package kestrel_<version>_<arch>.deb of what
# `cmake --install` puts under /usr (cmake/KestrelInstall.cmake, python/CMakeLists.txt).
# Its Depends: the shared libraries the binaries load (dpkg-shlibdeps), plus the -dev packages
# that find_package(Kestrel) and pkg-config need to build against the static libraries, and
# numpy for the Python module. The release preset is portable (no -march=native), so the
# package runs on any x86-64 CPU; a package of the `native` preset would not.
set(CPACK_PACKAGE_NAME kestrel)
set(CPACK_PACKAGE_VENDOR "Kestrel")
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY
    "On-board direct visual odometry and control for micro aerial vehicles")
set(CPACK_PACKAGE_DESCRIPTION
    "The kestrel command line, Kestrel's on-board static libraries with their headers, CMake \
package (find_package(Kestrel)) and pkg-config file, and the Python module `kestrel`.")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)  # kestrel_<version>_<arch>.deb
set(CPACK_DEBIAN_PACKAGE_MAINTAINER "Kestrel maintainers <kestrel@localhost>")
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(_deb_depends libeigen3-dev libopencv-dev libyaml-cpp-dev libhwy-dev)
if(KESTREL_PYTHON_MODULE_BUILT)
  # The module is built for one CPython ABI (e.g. cpython-311): the same minor version only.
  list(APPEND _deb_depends python3-numpy
       "python3 (>= ${KESTREL_PYTHON_VERSION_MINOR}), python3 (<< ${KESTREL_PYTHON_VERSION_NEXT})")
endif()
string(REPLACE ";" ", " CPACK_DEBIAN_PACKAGE_DEPENDS "${_deb_depends}")
set(CPACK_DEBIAN_PACKAGE_SUGGESTS "cmake, g++, pkg-config")
set(CPACK_OUTPUT_FILE_PREFIX ${PROJECT_BINARY_DIR}/packages)
include(CPack)
