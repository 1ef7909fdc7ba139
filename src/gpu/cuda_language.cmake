# Included by the top-level CMakeLists.txt: decides whether src/gpu builds its CUDA kernels and
# enables the CUDA language there (it must be enabled in the directory common to every target
# that links them). KESTREL_WITH_CUDA: AUTO (default) builds them when nvcc is found, except
# under KESTREL_SANITIZE (ASan and the CUDA runtime do not mix, and no sanitizer build here has
# a GPU to run them); ON requires nvcc; OFF never. Sets KESTREL_HAVE_CUDA.
set(KESTREL_WITH_CUDA AUTO CACHE STRING "Build the CUDA kernels of src/gpu: AUTO, ON or OFF")
set_property(CACHE KESTREL_WITH_CUDA PROPERTY STRINGS AUTO ON OFF)
set(KESTREL_HAVE_CUDA OFF)
set(_kestrel_cuda_why "KESTREL_WITH_CUDA=${KESTREL_WITH_CUDA}")
if(KESTREL_WITH_CUDA STREQUAL "AUTO" AND KESTREL_SANITIZE)
  set(_kestrel_cuda_why "AUTO under KESTREL_SANITIZE (set KESTREL_WITH_CUDA=ON to force)")
elseif(KESTREL_WITH_CUDA STREQUAL "AUTO" OR KESTREL_WITH_CUDA STREQUAL "ON")
  include(CheckLanguage)
  check_language(CUDA)
  if(CMAKE_CUDA_COMPILER)
    # Jetson Orin (sm_87) and H100/H200 (sm_90) machine code, plus sm_90 PTX for newer GPUs.
    # Two targets only: every architecture compiles each kernel again (CI time).
    if(NOT DEFINED CMAKE_CUDA_ARCHITECTURES AND NOT DEFINED ENV{CUDAARCHS})
      set(CMAKE_CUDA_ARCHITECTURES "87-real;90" CACHE STRING "CUDA architectures of src/gpu")
    endif()
    enable_language(CUDA)
    find_package(CUDAToolkit REQUIRED)  # CUDA::cudart_static, visible to every directory
    set(KESTREL_HAVE_CUDA ON)
    set(_kestrel_cuda_why "${CMAKE_CUDA_COMPILER} ${CMAKE_CUDA_COMPILER_VERSION}, architectures ${CMAKE_CUDA_ARCHITECTURES}")
  elseif(KESTREL_WITH_CUDA STREQUAL "ON")
    message(FATAL_ERROR "KESTREL_WITH_CUDA=ON but no CUDA compiler was found "
                        "(put nvcc on PATH or set CMAKE_CUDA_COMPILER)")
  else()
    set(_kestrel_cuda_why "AUTO: no nvcc found")
  endif()
elseif(NOT KESTREL_WITH_CUDA STREQUAL "OFF")
  message(FATAL_ERROR "KESTREL_WITH_CUDA must be AUTO, ON or OFF, got '${KESTREL_WITH_CUDA}'")
endif()
message(STATUS "Kestrel CUDA kernels: ${KESTREL_HAVE_CUDA} (${_kestrel_cuda_why})")
