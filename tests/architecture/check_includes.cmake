# Checks every Kestrel #include against the module graph that CMake wrote: a file of module M
# may include headers of M, of core, and of the modules M depends on (transitively), nothing
# else. Catches what the link check cannot: a header-only use of the simulator or the lab by an
# on-board module.
#
#   cmake -DGRAPH=build/<preset>/module_graph.txt -DROOT=<source dir> -P check_includes.cmake
#
# A header include/kestrel/<folder>/<name>.hpp (or a private src/<folder>/<name>.hpp) belongs to
# the module that compiles src/<folder>/<name>.cpp; otherwise to the module named after its
# folder, or else to the first module with sources in src/<folder>/.
cmake_minimum_required(VERSION 3.22)
foreach(var GRAPH ROOT)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "check_includes.cmake: -D${var}=... is required")
  endif()
endforeach()
if(NOT EXISTS "${GRAPH}")
  message(FATAL_ERROR "check_includes.cmake: ${GRAPH} does not exist (configure first)")
endif()

file(STRINGS "${GRAPH}" lines REGEX "^[a-z_]+ [a-z]+:")
set(modules core)
set(KIND_core onboard)
foreach(line IN LISTS lines)
  string(REGEX MATCH "^([a-z_]+) ([a-z]+):([^|]*)\\|(.*)$" _ "${line}")
  set(name ${CMAKE_MATCH_1})
  list(APPEND modules ${name})
  set(KIND_${name} ${CMAKE_MATCH_2})
  string(STRIP "${CMAKE_MATCH_3}" deps)
  string(STRIP "${CMAKE_MATCH_4}" sources)
  separate_arguments(DEPS_${name} UNIX_COMMAND "${deps}")
  separate_arguments(SOURCES_${name} UNIX_COMMAND "${sources}")
  foreach(src IN LISTS SOURCES_${name})
    # src/<folder>/<name>.cpp (or deeper): its header stem and its folder.
    if(src MATCHES "^src/([a-z_0-9]+)/(.+)\\.(cpp|cu)$")
      set(OWNER_${CMAKE_MATCH_1}/${CMAKE_MATCH_2} ${name})
      if(NOT DEFINED FOLDER_DEFAULT_${CMAKE_MATCH_1})
        set(FOLDER_DEFAULT_${CMAKE_MATCH_1} ${name})
      endif()
    endif()
  endforeach()
endforeach()
foreach(name IN LISTS modules)
  if(DEFINED KIND_${name})
    set(FOLDER_DEFAULT_${name} ${name})  # a module named after its folder owns the rest of it
  endif()
endforeach()

# module_of(<folder>/<path without extension>) -> out
function(module_of key out)
  if(DEFINED OWNER_${key})
    set(${out} ${OWNER_${key}} PARENT_SCOPE)
    return()
  endif()
  string(REGEX MATCH "^[a-z_0-9]+" folder "${key}")
  if(DEFINED FOLDER_DEFAULT_${folder})
    set(${out} ${FOLDER_DEFAULT_${folder}} PARENT_SCOPE)
  else()
    set(${out} "" PARENT_SCOPE)
  endif()
endfunction()

# Transitive closure of each module's dependencies.
foreach(name IN LISTS modules)
  set(closure "")
  set(queue ${DEPS_${name}})
  while(queue)
    list(POP_FRONT queue dep)
    if(NOT dep IN_LIST closure)
      list(APPEND closure ${dep})
      list(APPEND queue ${DEPS_${dep}})
    endif()
  endwhile()
  set(CLOSURE_${name} ${closure})
endforeach()

# Every file of every module: its sources, its public headers, its private headers.
file(GLOB_RECURSE headers RELATIVE "${ROOT}" "${ROOT}/include/kestrel/*.hpp" "${ROOT}/src/*.hpp"
     "${ROOT}/src/*.cuh")
set(files "")
foreach(name IN LISTS modules)
  foreach(src IN LISTS SOURCES_${name})
    list(APPEND files ${src})
    set(FILE_MODULE_${src} ${name})
  endforeach()
endforeach()
foreach(h IN LISTS headers)
  if(h MATCHES "^(include/kestrel|src)/(.+)\\.(hpp|cuh)$")
    module_of("${CMAKE_MATCH_2}" owner)
    if(owner)
      list(APPEND files ${h})
      set(FILE_MODULE_${h} ${owner})
    endif()
  endif()
endforeach()

set(violations "")
set(checked 0)
foreach(f IN LISTS files)
  set(owner ${FILE_MODULE_${f}})
  file(STRINGS "${ROOT}/${f}" includes REGEX "^[ \t]*#[ \t]*include[ \t]+\"kestrel/")
  foreach(inc IN LISTS includes)
    string(REGEX MATCH "\"kestrel/([^\"]+)\\.(hpp|cuh)\"" _ "${inc}")
    set(target_key ${CMAKE_MATCH_1})
    module_of("${target_key}" target)
    math(EXPR checked "${checked} + 1")
    if(NOT target)
      string(APPEND violations "  ${f}: includes kestrel/${target_key}, which no module owns\n")
    elseif(NOT target STREQUAL owner AND NOT target STREQUAL "core"
           AND NOT target IN_LIST CLOSURE_${owner})
      string(APPEND violations "  ${f} (module ${owner}, ${KIND_${owner}}): includes "
                               "kestrel/${target_key} of module ${target} (${KIND_${target}}), "
                               "which ${owner} does not depend on\n")
    endif()
  endforeach()
endforeach()

list(LENGTH files nfiles)
if(violations)
  message(FATAL_ERROR "includes that break the module graph (fix the include or the DEPS of the "
                      "module's CMakeLists.txt; on-board modules may not depend on sim, lab, "
                      "flight or eval):\n${violations}")
endif()
message(STATUS "check_includes: ${nfiles} files, ${checked} Kestrel includes, all within the graph")
