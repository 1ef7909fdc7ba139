# Compiler flags shared by every Kestrel target: warnings, sanitizers, CPU tuning.
add_library(kestrel_options INTERFACE)
target_compile_options(kestrel_options INTERFACE
  -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wcast-align -Wunused
  -Woverloaded-virtual -Wnull-dereference -Wdouble-promotion -Wformat=2)
# Clang's -Wdouble-promotion also flags every float widened to double by an initialisation or
# an argument (`double z = z_row[u]`, cv::Scalar(float, ...)), which GCC's flags only inside
# arithmetic: 24 warnings in the fuzz preset's clang build, none a loss of precision (widening
# loses none). GCC builds keep the warning.
if(CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
  target_compile_options(kestrel_options INTERFACE -Wno-double-promotion)
endif()
# With -fPIC (CMAKE_POSITION_INDEPENDENT_CODE, for the Python module) GCC assumes any exported
# function may be replaced at load time and stops inlining and cloning calls between them;
# Kestrel's functions are never interposed, so keep the code of a non-PIC build.
target_compile_options(kestrel_options INTERFACE -fno-semantic-interposition)
if(KESTREL_NATIVE)
  target_compile_options(kestrel_options INTERFACE -march=native)
  # On a CPU whose baseline is Highway's AVX3_DL (AVX-512 with VNNI, VBMI2, BITALG: Ice Lake,
  # Zen 4), Highway 1.0.3 leaves that static target out of the attainable ones unless asked for,
  # and every file including it stops with "best baseline should be included in dynamic targets".
  target_compile_definitions(kestrel_options INTERFACE HWY_WANT_AVX3_DL)
  # GCC 12 flags Eigen's unaligned AVX packet loads of fixed-size vectors (e.g. a Vector3d
  # comma-initialised into a Vector6d) as out of bounds: a known false positive of its
  # -Warray-bounds with -march=native. The ASan build checks real bounds.
  # On a CPU with AVX-512, GCC 12's avx512fintrin.h initialises `__Y` from itself (GCC bug
  # 105593, fixed in 13): every Eigen 512-bit extract then warns "may be used uninitialized"
  # (~340 warnings per build, none in our code). The asan preset, built without -march=native,
  # keeps both warnings on for all of Kestrel's code.
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND CMAKE_CXX_COMPILER_VERSION VERSION_LESS 13)
    target_compile_options(kestrel_options INTERFACE -Wno-array-bounds -Wno-maybe-uninitialized
                                                     -Wno-uninitialized)
  endif()
endif()
if(KESTREL_SANITIZE)
  # UBSan without its `alignment` and `null` checks: they instrument every reference binding and
  # member access, which in Eigen's expression templates costs as much compile time as all the
  # rest (tests/geometry/test_se3.cpp at -O1: 61.5 s with them, 29.9 s without, 14.8 s
  # unsanitised; the whole asan unity build on 2 cores 670 -> 497 s, its tests 328 -> 284 s).
  # A null dereference still stops the run (ASan reports the SEGV with its stack), and a
  # misaligned SIMD load faults the same way; the other UBSan checks (signed overflow,
  # shifts, division by zero, bounds, object size, pointer overflow, vptr, enums, bools, returns,
  # builtins, unreachable) stay on.
  target_compile_options(kestrel_options INTERFACE
    -fsanitize=address,undefined -fno-sanitize=alignment,null -fno-omit-frame-pointer
    -fno-sanitize-recover=undefined)
  target_link_options(kestrel_options INTERFACE -fsanitize=address,undefined)
endif()
