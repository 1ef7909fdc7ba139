# What `cmake --install` puts under the prefix: the `kestrel` CLI, the libraries a vehicle
# links (the on-board modules) and the evaluation tool, their headers, the CMake package
# lib/cmake/Kestrel (find_package(Kestrel): Kestrel::<module> and Kestrel::kestrel) and
# lib/pkgconfig/kestrel.pc. The simulator, the lab, the flight loop, the tests and the ROS
# adapter (built only where ROS is, packaged by nobody) stay in the build tree.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

# The installed modules, in link order (a module before those it uses): a depth-first walk of
# the module graph, reversed, so that pkg-config's -l list links a static archive before the
# archives it needs.
function(_kestrel_install_order module visited_var order_var)
  set(visited ${${visited_var}})
  set(order ${${order_var}})
  if(module IN_LIST visited)
    return()
  endif()
  list(APPEND visited ${module})
  get_property(deps GLOBAL PROPERTY KESTREL_MODULE_DEPS_${module})
  foreach(dep IN LISTS deps)
    _kestrel_install_order(${dep} visited order)
  endforeach()
  list(PREPEND order ${module})
  set(${visited_var} ${visited} PARENT_SCOPE)
  set(${order_var} ${order} PARENT_SCOPE)
endfunction()

set(_kestrel_installed "")
get_property(_kestrel_modules GLOBAL PROPERTY KESTREL_MODULES)
foreach(_module IN LISTS _kestrel_modules)
  get_property(_kind GLOBAL PROPERTY KESTREL_MODULE_KIND_${_module})
  if(_kind MATCHES "^(onboard|tool)$" AND NOT _module MATCHES "^ros_")
    list(APPEND _kestrel_installed ${_module})
  endif()
endforeach()
set(_visited "")
set(KESTREL_INSTALLED_MODULES "")  # link order, for kestrel.pc and the docs' check
foreach(_module IN LISTS _kestrel_installed)
  _kestrel_install_order(${_module} _visited KESTREL_INSTALLED_MODULES)
endforeach()
list(REMOVE_ITEM KESTREL_INSTALLED_MODULES core)  # header-only: no archive
set(KESTREL_INSTALLED_MODULES ${KESTREL_INSTALLED_MODULES} CACHE INTERNAL
    "Kestrel modules that cmake --install installs, in link order")

# Kestrel::kestrel: every installed module, for users who do not want to pick.
add_library(kestrel_all INTERFACE)
set_target_properties(kestrel_all PROPERTIES EXPORT_NAME kestrel)
set(_targets kestrel_core kestrel_all)
foreach(_module IN LISTS KESTREL_INSTALLED_MODULES)
  target_link_libraries(kestrel_all INTERFACE kestrel_${_module})
  list(APPEND _targets kestrel_${_module})
endforeach()
if(KESTREL_HAVE_CUDA)
  list(APPEND _targets kestrel_gpu_kernels)  # linked by kestrel_gpu
endif()

install(TARGETS ${_targets} EXPORT KestrelTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT dev)
install(TARGETS kestrel RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT cli)

# Headers: each installed module's folder of include/kestrel (stereo_odometry shares odometry's).
foreach(_module core ${KESTREL_INSTALLED_MODULES})
  if(IS_DIRECTORY ${PROJECT_SOURCE_DIR}/include/kestrel/${_module})
    install(DIRECTORY ${PROJECT_SOURCE_DIR}/include/kestrel/${_module}
            DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/kestrel COMPONENT dev)
  endif()
endforeach()

set(KESTREL_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/Kestrel)
install(EXPORT KestrelTargets NAMESPACE Kestrel:: DESTINATION ${KESTREL_CMAKE_DIR}
        COMPONENT dev)
string(REPLACE ";" " " KESTREL_COMPONENTS "${KESTREL_INSTALLED_MODULES}")
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/KestrelConfig.cmake.in
  ${PROJECT_BINARY_DIR}/KestrelConfig.cmake INSTALL_DESTINATION ${KESTREL_CMAKE_DIR})
# 0.x: a minor version may break the API, so a request for 0.1 accepts 0.1.* only.
write_basic_package_version_file(${PROJECT_BINARY_DIR}/KestrelConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/KestrelConfig.cmake
              ${PROJECT_BINARY_DIR}/KestrelConfigVersion.cmake
        DESTINATION ${KESTREL_CMAKE_DIR} COMPONENT dev)

# pkg-config: the archives in link order, then what they need. KESTREL_HAVE_CUDA is a public
# definition of the gpu module's headers, so it is part of the flags.
set(KESTREL_PC_LIBS "")
foreach(_module IN LISTS KESTREL_INSTALLED_MODULES)
  string(APPEND KESTREL_PC_LIBS " -lkestrel_${_module}")
endforeach()
if(KESTREL_HAVE_CUDA)
  set(KESTREL_PC_CUDA_DEFINE 1)
  string(APPEND KESTREL_PC_LIBS
         " -lkestrel_gpu_kernels -L${CUDAToolkit_LIBRARY_DIR} -lcudart_static -ldl -lrt")
else()
  set(KESTREL_PC_CUDA_DEFINE 0)
endif()
# The prefix relative to the .pc file itself, so that the tree works wherever it is installed
# (`cmake --install --prefix` chooses it after configuring).
file(RELATIVE_PATH KESTREL_PC_UP /p/${CMAKE_INSTALL_LIBDIR}/pkgconfig /p)
configure_file(${PROJECT_SOURCE_DIR}/cmake/kestrel.pc.in ${PROJECT_BINARY_DIR}/kestrel.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/kestrel.pc
        DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig COMPONENT dev)
