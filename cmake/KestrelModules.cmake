# Kestrel's modules, their graph, and its one rule: what flies never links the lab.
#
# Every module registers its kind (onboard, tool or lab) and its direct Kestrel dependencies.
# After all modules are declared, kestrel_check_module_rules() walks each on-board module's
# dependencies transitively and stops the configure step if one reaches a module that is not
# on-board, naming the chain. It also writes build/<preset>/module_graph.txt (one "module kind: deps" line per
# module), which tests/architecture compares with docs/architecture.md and with the #include
# lines of the sources.

# kestrel_add_module(NAME KIND onboard|tool|lab SOURCES ... DEPS ...): one static library per
# part of the system. KIND says where it belongs (docs/architecture.md): `onboard`, what a vehicle
# links; `tool`, what the CLI and the lab use around it (evaluation); `lab`, the simulator,
# experiments and studies. kestrel_check_module_rules() checks that an on-board module reaches
# on-board modules only.
function(kestrel_add_module name)
  cmake_parse_arguments(ARG "" "KIND" "SOURCES;DEPS" ${ARGN})
  if(NOT ARG_KIND MATCHES "^(onboard|tool|lab)$")
    message(FATAL_ERROR "kestrel_add_module(${name}): KIND must be onboard, tool or lab")
  endif()
  add_library(kestrel_${name} STATIC ${ARG_SOURCES})
  add_library(kestrel::${name} ALIAS kestrel_${name})
  # Installed, the module is Kestrel::<name> (cmake/KestrelInstall.cmake) and finds its headers
  # under the prefix; the warning flags stay Kestrel's own (BUILD_INTERFACE), never a user's.
  set_target_properties(kestrel_${name} PROPERTIES EXPORT_NAME ${name})
  target_include_directories(kestrel_${name} PUBLIC
    $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/include> $<INSTALL_INTERFACE:include>)
  target_link_libraries(kestrel_${name} PUBLIC ${ARG_DEPS}
                                        PRIVATE $<BUILD_INTERFACE:kestrel_options>)
  kestrel_register_module(${name} ${ARG_KIND} "${ARG_DEPS}")
endfunction()

# kestrel_register_module(NAME KIND DEPS): records a module for the checks below.
function(kestrel_register_module name kind deps)
  set(kestrel_deps "")
  foreach(dep IN LISTS deps)
    if(dep MATCHES "^kestrel::(.+)$")
      list(APPEND kestrel_deps ${CMAKE_MATCH_1})
    endif()
  endforeach()
  set_property(GLOBAL APPEND PROPERTY KESTREL_MODULES ${name})
  set_property(GLOBAL PROPERTY KESTREL_MODULE_KIND_${name} ${kind})
  set_property(GLOBAL PROPERTY KESTREL_MODULE_DEPS_${name} "${kestrel_deps}")
endfunction()

# Depth-first search from `module` for a module that is not on-board; sets `out` to the chain
# found or "".
function(_kestrel_find_offboard_chain module chain out)
  get_property(deps GLOBAL PROPERTY KESTREL_MODULE_DEPS_${module})
  foreach(dep IN LISTS deps)
    get_property(kind GLOBAL PROPERTY KESTREL_MODULE_KIND_${dep})
    if(NOT kind STREQUAL "onboard" AND NOT dep STREQUAL "core")
      set(${out} "${chain} -> ${dep} (${kind})" PARENT_SCOPE)
      return()
    endif()
    _kestrel_find_offboard_chain(${dep} "${chain} -> ${dep}" found)
    if(found)
      set(${out} "${found}" PARENT_SCOPE)
      return()
    endif()
  endforeach()
  set(${out} "" PARENT_SCOPE)
endfunction()

function(kestrel_check_module_rules)
  get_property(modules GLOBAL PROPERTY KESTREL_MODULES)
  set(graph "# module kind: direct Kestrel dependencies | sources (written by CMake; do not edit)\n")
  foreach(module IN LISTS modules)
    get_property(kind GLOBAL PROPERTY KESTREL_MODULE_KIND_${module})
    get_property(deps GLOBAL PROPERTY KESTREL_MODULE_DEPS_${module})
    foreach(dep IN LISTS deps)
      get_property(dep_kind GLOBAL PROPERTY KESTREL_MODULE_KIND_${dep})
      if(NOT dep_kind AND NOT dep STREQUAL "core")
        message(FATAL_ERROR "module ${module} depends on kestrel::${dep}, which is not declared "
                            "before it (add_subdirectory order in CMakeLists.txt)")
      endif()
    endforeach()
    if(kind STREQUAL "onboard")
      _kestrel_find_offboard_chain(${module} ${module} chain)
      if(chain)
        message(FATAL_ERROR "on-board module ${module} reaches a module that does not fly: "
                            "${chain}. What flies never links the simulator, an experiment or "
                            "the evaluation tools (docs/architecture.md).")
      endif()
    endif()
    # The module's sources, relative to the project root, for the include check of
    # tests/architecture (a folder may hold two modules, e.g. odometry and stereo_odometry).
    set(sources "")
    if(TARGET kestrel_${module})
      get_target_property(dir kestrel_${module} SOURCE_DIR)
      get_target_property(files kestrel_${module} SOURCES)
      file(RELATIVE_PATH rel_dir ${PROJECT_SOURCE_DIR} ${dir})
      foreach(f IN LISTS files)
        if(f MATCHES "\\.(cpp|hpp|cu)$")
          list(APPEND sources ${rel_dir}/${f})
        endif()
      endforeach()
    endif()
    string(REPLACE ";" " " deps_text "${deps}")
    string(REPLACE ";" " " sources_text "${sources}")
    string(APPEND graph "${module} ${kind}: ${deps_text} | ${sources_text}\n")
  endforeach()
  file(WRITE ${CMAKE_BINARY_DIR}/module_graph.txt "${graph}")
endfunction()
