# Checks that docs/architecture.md shows the module graph CMake built: the block between
# <!-- module-graph:begin --> and <!-- module-graph:end --> must list, line for line, each
# module as "name (kind): dependencies". Modules that this build left out (the optional ROS
# adapter) are skipped. On a mismatch it prints the block to paste.
#
#   cmake -DGRAPH=build/<preset>/module_graph.txt -DDOC=docs/architecture.md -P check_docs_graph.cmake
cmake_minimum_required(VERSION 3.22)
file(STRINGS "${GRAPH}" lines REGEX "^[a-z_]+ [a-z]+:")
set(expected "")
set(built "")
foreach(line IN LISTS lines)
  string(REGEX MATCH "^([a-z_]+) ([a-z]+):([^|]*)\\|" _ "${line}")
  string(STRIP "${CMAKE_MATCH_3}" deps)
  list(APPEND built ${CMAKE_MATCH_1})
  string(APPEND expected "${CMAKE_MATCH_1} (${CMAKE_MATCH_2}): ${deps}\n")
endforeach()

file(READ "${DOC}" doc)
string(FIND "${doc}" "<!-- module-graph:begin -->" begin)
string(FIND "${doc}" "<!-- module-graph:end -->" end)
if(begin EQUAL -1 OR end EQUAL -1 OR end LESS begin)
  message(FATAL_ERROR "${DOC}: no <!-- module-graph:begin --> ... <!-- module-graph:end --> block")
endif()
string(SUBSTRING "${doc}" ${begin} ${end}-${begin} block)
string(REGEX MATCHALL "\n[a-z_]+ \\([a-z]+\\):[^\n]*" shown "${block}")
set(actual "")
foreach(line IN LISTS shown)
  string(STRIP "${line}" line)
  # An optional module this build left out (ros_* without ROS) is not compared.
  string(REGEX MATCH "^[a-z_]+" name "${line}")
  if(name IN_LIST built)
    string(APPEND actual "${line}\n")
  endif()
endforeach()
if(NOT actual STREQUAL expected)
  message(FATAL_ERROR "${DOC}: the module graph block differs from the build's. It should read:\n"
                      "```text\n${expected}```")
endif()
message(STATUS "check_docs_graph: ${DOC} shows the build's module graph")
