# cmake -DDOXYGEN=... -DDOXYFILE=... -DLOG=... -P run_doxygen.cmake: runs Doxygen and fails,
# printing them, if it wrote any warning to LOG (the Doxyfile's WARN_LOGFILE).
file(REMOVE ${LOG})
execute_process(COMMAND ${DOXYGEN} ${DOXYFILE} RESULT_VARIABLE status OUTPUT_QUIET)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "doxygen ${DOXYFILE} failed (exit status ${status})")
endif()
file(READ ${LOG} warnings)
if(NOT warnings STREQUAL "")
  message(FATAL_ERROR "Doxygen warned (${LOG}):\n${warnings}")
endif()
get_filename_component(out ${LOG} DIRECTORY)
message(STATUS "Doxygen: no warnings; ${out}/html/index.html")
