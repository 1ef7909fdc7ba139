# The API reference (docs/api.md): Doxygen over the public headers of the installed modules.
# `cmake --build build/<preset> --target docs` writes build/<preset>/docs/api/html/; the test
# Docs.DoxygenWithoutWarnings fails on any Doxygen warning. Both need Debian's `doxygen`.
find_program(KESTREL_DOXYGEN doxygen)
if(NOT KESTREL_DOXYGEN)
  message(STATUS "Doxygen not found: no `docs` target or documentation test")
  return()
endif()
set(KESTREL_DOXYGEN_OUT ${PROJECT_BINARY_DIR}/docs/api)
set(KESTREL_DOXYGEN_INPUT "")
foreach(_module core ${KESTREL_INSTALLED_MODULES})
  if(IS_DIRECTORY ${PROJECT_SOURCE_DIR}/include/kestrel/${_module})
    string(APPEND KESTREL_DOXYGEN_INPUT " ${PROJECT_SOURCE_DIR}/include/kestrel/${_module}")
  endif()
endforeach()
configure_file(${PROJECT_SOURCE_DIR}/docs/Doxyfile.in ${KESTREL_DOXYGEN_OUT}/Doxyfile @ONLY)
add_custom_target(docs
  COMMAND ${CMAKE_COMMAND} -DDOXYGEN=${KESTREL_DOXYGEN} -DDOXYFILE=${KESTREL_DOXYGEN_OUT}/Doxyfile
          -DLOG=${KESTREL_DOXYGEN_OUT}/warnings.log -P ${PROJECT_SOURCE_DIR}/cmake/run_doxygen.cmake
  COMMENT "Doxygen: ${KESTREL_DOXYGEN_OUT}/html/index.html" VERBATIM)
if(KESTREL_BUILD_TESTS)
  add_test(NAME Docs.DoxygenWithoutWarnings
           COMMAND ${CMAKE_COMMAND} -DDOXYGEN=${KESTREL_DOXYGEN}
                   -DDOXYFILE=${KESTREL_DOXYGEN_OUT}/Doxyfile
                   -DLOG=${KESTREL_DOXYGEN_OUT}/warnings.log
                   -P ${PROJECT_SOURCE_DIR}/cmake/run_doxygen.cmake)
  set_tests_properties(Docs.DoxygenWithoutWarnings PROPERTIES LABELS docs TIMEOUT 300)
endif()
