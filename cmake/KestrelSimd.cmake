# Portable SIMD kernels with Google Highway (Debian libhwy-dev): each kernel is written once and
# compiled for every x86 (SSSE3, SSE4, AVX2, AVX-512) or ARM (NEON) target the compiler can
# emit, plus Highway's portable 128-bit emulation; at run time each call goes to the best target
# the CPU supports. Compiling all of them (HWY_COMPILE_ALL_ATTAINABLE), not just those above
# -march's baseline, lets the tests check every target on one machine and keeps a binary built
# without -march=native fast. SVE is left out: the kernels keep vectors in arrays, which SVE's
# sizeless vector types do not allow.
find_package(hwy REQUIRED)

# Which targets the Highway translation units compile: all attainable ones, except in the fuzz
# build, whose targets exercise parsers, not kernels: there the one static target is enough, and
# compiling every target under clang's sanitizers took ~8 minutes of a CI run.
if(KESTREL_FUZZ)
  set(KESTREL_HWY_COMPILE HWY_COMPILE_ONLY_STATIC)
else()
  set(KESTREL_HWY_COMPILE HWY_COMPILE_ALL_ATTAINABLE)
endif()

# kestrel_use_highway(MODULE SOURCES...): MODULE links Highway; SOURCES are Highway
# translation units that re-include themselves by file name (HWY_TARGET_INCLUDE).
function(kestrel_use_highway module)
  target_link_libraries(kestrel_${module} PRIVATE hwy::hwy)
  target_include_directories(kestrel_${module} PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
  set_source_files_properties(${ARGN} DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR} PROPERTIES
    COMPILE_DEFINITIONS
      "${KESTREL_HWY_COMPILE};HWY_DISABLED_TARGETS=(HWY_SVE|HWY_SVE2|HWY_SVE_256|HWY_SVE2_128)")
endfunction()
