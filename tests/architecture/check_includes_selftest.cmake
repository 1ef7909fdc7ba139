# Shows that check_includes.cmake and the configure-time rule of cmake/KestrelModules.cmake can
# fail: on a small made-up tree where an on-board module includes (or links) a lab module, both
# must stop with a message naming the file or the chain; on the same tree without the bad
# include, the include check must pass.
#
#   cmake -DROOT=<source dir> -DWORK=<scratch folder> -P check_includes_selftest.cmake
cmake_minimum_required(VERSION 3.22)
file(REMOVE_RECURSE "${WORK}")
file(WRITE "${WORK}/graph.txt" "# test graph\n"
           "flyer onboard: core | src/flyer/flyer.cpp\n"
           "labby lab: flyer | src/labby/labby.cpp\n")
file(WRITE "${WORK}/include/kestrel/flyer/flyer.hpp" "#pragma once\n")
file(WRITE "${WORK}/include/kestrel/labby/labby.hpp" "#pragma once\n#include \"kestrel/flyer/flyer.hpp\"\n")
file(WRITE "${WORK}/src/labby/labby.cpp" "#include \"kestrel/labby/labby.hpp\"\n")

function(run_check expect_ok what)
  execute_process(COMMAND ${CMAKE_COMMAND} -DGRAPH=${WORK}/graph.txt -DROOT=${WORK}
                          -P ${ROOT}/tests/architecture/check_includes.cmake
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(expect_ok AND NOT rc EQUAL 0)
    message(FATAL_ERROR "${what}: the include check failed on a clean tree:\n${out}${err}")
  endif()
  if(NOT expect_ok)
    if(rc EQUAL 0)
      message(FATAL_ERROR "${what}: the include check passed a lab include in an on-board file")
    endif()
    string(REGEX REPLACE "[ \n]+" " " err "${err}")  # CMake wraps long messages
    if(NOT err MATCHES "src/flyer/flyer.cpp \\(module flyer, onboard\\): includes kestrel/labby/labby")
      message(FATAL_ERROR "${what}: the message does not name the file and the include:\n${err}")
    endif()
  endif()
endfunction()

file(WRITE "${WORK}/src/flyer/flyer.cpp" "#include \"kestrel/flyer/flyer.hpp\"\n")
run_check(TRUE "clean tree")
file(WRITE "${WORK}/src/flyer/flyer.cpp"
     "#include \"kestrel/flyer/flyer.hpp\"\n#include \"kestrel/labby/labby.hpp\"\n")
run_check(FALSE "on-board file including a lab header")

# The configure-time link rule, on registered modules: flyer -> middle -> labby must stop.
file(WRITE "${WORK}/link_rule.cmake"
     "include(${ROOT}/cmake/KestrelModules.cmake)\n"
     "kestrel_register_module(labby lab \"\")\n"
     "kestrel_register_module(middle onboard \"kestrel::labby\")\n"
     "kestrel_register_module(flyer onboard \"kestrel::middle\")\n"
     "kestrel_check_module_rules()\n")
execute_process(COMMAND ${CMAKE_COMMAND} -DPROJECT_SOURCE_DIR=${WORK} -P ${WORK}/link_rule.cmake
                WORKING_DIRECTORY ${WORK} RESULT_VARIABLE rc ERROR_VARIABLE err)
string(REGEX REPLACE "[ \n]+" " " err "${err}")  # CMake wraps long messages
if(rc EQUAL 0)
  message(FATAL_ERROR "the link rule let an on-board module reach a lab module")
endif()
if(NOT err MATCHES "on-board module middle reaches a module that does not fly: middle -> labby \\(lab\\)")
  message(FATAL_ERROR "the link rule's message does not name the chain:\n${err}")
endif()
message(STATUS "check_includes_selftest: both checks fail on a bad tree and pass a clean one")
