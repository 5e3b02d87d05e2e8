# Every third-party dependency, found once. The learned core (util, geometry, nerf, reg, dbarf)
# needs only Torch, Eigen and header-only libraries; Embree, Open3D, OpenCV and Ceres are used by
# the edge libraries alone, so the core can be rebuilt against a CUDA LibTorch elsewhere.
find_package(Threads REQUIRED)
find_package(OpenMP REQUIRED)
if(NERFREG_WITH_TORCH)
  # A LibTorch named by Torch_DIR (the CUDA build's wheel) must not be mixed with another one on
  # the system's paths: its TorchConfig asks for Caffe2 and its libraries with PATHS, which CMake
  # searches after the default paths, so on a machine with Debian's libtorch-dev the build took
  # Debian's Caffe2 targets and libtorch 1.13 beside the wheel's headers and failed to link. Its
  # package and library folders are fixed here first.
  if(Torch_DIR AND EXISTS "${Torch_DIR}/../Caffe2/Caffe2Config.cmake")
    get_filename_component(nerfreg_torch_lib "${Torch_DIR}/../../../lib" ABSOLUTE)
    set(Caffe2_DIR "${Torch_DIR}/../Caffe2" CACHE PATH "Caffe2 config beside Torch_DIR" FORCE)
    foreach(lib torch torch_cpu torch_cuda c10 c10_cuda kineto)
      find_library(${lib}_LIBRARY ${lib} PATHS "${nerfreg_torch_lib}" NO_DEFAULT_PATH)
    endforeach()
    find_library(TORCH_LIBRARY torch PATHS "${nerfreg_torch_lib}" NO_DEFAULT_PATH)
    find_library(C10_CUDA_LIBRARY c10_cuda PATHS "${nerfreg_torch_lib}" NO_DEFAULT_PATH)
    find_library(CAFFE2_NVRTC_LIBRARY caffe2_nvrtc PATHS "${nerfreg_torch_lib}" NO_DEFAULT_PATH)
  endif()
  # LibTorch's CUDA config compiles for TORCH_CUDA_ARCH_LIST and turns CMAKE_CUDA_ARCHITECTURES
  # off; unset and with no GPU present, its default list starts at compute_50, which nvcc 13 no
  # longer has. The architectures asked for (e.g. 90-real;90-virtual) are passed on in its terms.
  if(NERFREG_CUDA AND NOT DEFINED TORCH_CUDA_ARCH_LIST AND NOT DEFINED ENV{TORCH_CUDA_ARCH_LIST}
     AND CMAKE_CUDA_ARCHITECTURES MATCHES "^[0-9]")
    set(nerfreg_arch_list "")
    foreach(arch ${CMAKE_CUDA_ARCHITECTURES})
      string(REGEX REPLACE "^([0-9]+)([0-9])([a-z]?)(-real|-virtual)?$" "\\1.\\2\\3" dotted "${arch}")
      if(arch MATCHES "-virtual$")
        string(APPEND dotted "+PTX")
        list(REMOVE_ITEM nerfreg_arch_list "${dotted}")
        string(REPLACE "+PTX" "" plain "${dotted}")
        list(REMOVE_ITEM nerfreg_arch_list "${plain}")
      endif()
      list(APPEND nerfreg_arch_list "${dotted}")
    endforeach()
    list(REMOVE_DUPLICATES nerfreg_arch_list)
    set(TORCH_CUDA_ARCH_LIST "${nerfreg_arch_list}")
    message(STATUS "nerfreg: TORCH_CUDA_ARCH_LIST ${TORCH_CUDA_ARCH_LIST} (from CMAKE_CUDA_ARCHITECTURES)")
  endif()
  find_package(Torch REQUIRED)
endif()
find_package(Eigen3 3.3 REQUIRED NO_MODULE)
find_package(nlohmann_json REQUIRED)
find_package(CLI11 REQUIRED)
find_package(fmt REQUIRED)
find_package(spdlog REQUIRED)
find_package(ZLIB REQUIRED)
# libexif (Debian's libexif-dev) reads the camera facts of photos' EXIF blocks (util/exif.cc).
# pkg-config, where present, only hints the folders: find_path / find_library also search
# CMAKE_PREFIX_PATH, which is how a GPU machine without the package finds the copy unpacked from
# scripts/gpu_deps.sh (its libexif.pc names /usr, not the unpacked folder).
find_package(PkgConfig QUIET)
if(PKG_CONFIG_FOUND)
  pkg_check_modules(PC_LIBEXIF QUIET libexif)
endif()
find_path(LIBEXIF_INCLUDE_DIR libexif/exif-data.h HINTS ${PC_LIBEXIF_INCLUDE_DIRS})
find_library(LIBEXIF_LIBRARY exif HINTS ${PC_LIBEXIF_LIBRARY_DIRS})
if(NOT LIBEXIF_INCLUDE_DIR OR NOT LIBEXIF_LIBRARY)
  message(FATAL_ERROR "libexif not found: install libexif-dev (scripts/setup.sh)")
endif()
add_library(nerfreg_libexif INTERFACE)
target_include_directories(nerfreg_libexif SYSTEM INTERFACE ${LIBEXIF_INCLUDE_DIR})
target_link_libraries(nerfreg_libexif INTERFACE ${LIBEXIF_LIBRARY})
if(NOT NERFREG_LEARNED_CORE_ONLY)
  find_package(embree 3 REQUIRED)
  find_package(Open3D REQUIRED)
  find_package(Ceres REQUIRED)
  find_package(OpenCV REQUIRED COMPONENTS core imgproc features2d calib3d)
  # oneDNN (libdnnl2 is LibTorch's own dependency; libdnnl-dev adds its headers): the SIFT
  # matcher's u8 x s8 descriptor products (viewgraph/view_graph.cc).
  find_package(dnnl CONFIG REQUIRED)
endif()
if(NERFREG_BUILD_TESTS)
  find_package(GTest REQUIRED)
endif()
if(NERFREG_BUILD_BENCH AND NOT NERFREG_LEARNED_CORE_ONLY)
  find_package(benchmark REQUIRED)
endif()

# Torch's imported target carries flags (-D_GLIBCXX_USE_CXX11_ABI, include dirs); wrap it so the
# layers link one name.
if(NERFREG_WITH_TORCH)
  message(STATUS "nerfreg: LibTorch ${Torch_VERSION} from ${Torch_DIR}")
  add_library(nerfreg_torch INTERFACE)
  target_link_libraries(nerfreg_torch INTERFACE ${TORCH_LIBRARIES} OpenMP::OpenMP_CXX)
  target_include_directories(nerfreg_torch SYSTEM INTERFACE ${TORCH_INCLUDE_DIRS})
  # LibTorch 2.x (PyPI) ships fmt 12's headers in its include folder, and they shadow the system's
  # fmt that spdlog was built with (Debian: fmt 9; spdlog's headers then fail to compile). A folder
  # holding only a link to the system's fmt/ goes before Torch's. (torch/torch.h itself does not
  # include fmt.) Debian's LibTorch shares /usr/include with fmt: nothing to do there.
  get_target_property(nerfreg_fmt_include fmt::fmt INTERFACE_INCLUDE_DIRECTORIES)
  foreach(dir ${TORCH_INCLUDE_DIRS})
    if(nerfreg_fmt_include AND EXISTS "${dir}/fmt/core.h" AND NOT dir STREQUAL nerfreg_fmt_include
       AND EXISTS "${nerfreg_fmt_include}/fmt/core.h")
      file(MAKE_DIRECTORY ${PROJECT_BINARY_DIR}/system_fmt)
      file(CREATE_LINK ${nerfreg_fmt_include}/fmt ${PROJECT_BINARY_DIR}/system_fmt/fmt SYMBOLIC)
      target_include_directories(nerfreg_torch SYSTEM BEFORE INTERFACE ${PROJECT_BINARY_DIR}/system_fmt)
      break()
    endif()
  endforeach()
endif()

# BLAS: Debian's Ceres links ATLAS's libf77blas.so.3 directly. An executable that lists it before
# libblas.so.3 (the alternative setup.sh points at OpenBLAS) resolves LibTorch's sgemm_ to
# single-threaded ATLAS: `perf` showed ATL_* kernels taking most of a `reg train` step, and
# putting OpenBLAS first doubled its rate (0.28 -> 0.58 steps/s, 2 cores, shared machine). Every
# executable therefore names libblas.so.3 first (nerfreg_runtime_first in NerfregMacros.cmake).
find_file(NERFREG_BLAS_LIBRARY libblas.so.3 PATHS /usr/lib/x86_64-linux-gnu /usr/lib/aarch64-linux-gnu /usr/lib NO_DEFAULT_PATH)

# Executables name the shared libstdc++ first (nerfreg_runtime_first) in two cases:
# - A LibTorch from PyTorch's wheels (built on manylinux_2_28 by a newer GCC, which links the parts
#   of libstdc++ the older system lacks statically) exports some std:: functions itself,
#   std::filesystem's among them. An executable that lists libtorch.so before libstdc++.so.6 binds
#   its own calls to those copies: std::filesystem::remove_all jumped to address 0 in the
#   temporary-folder clean-up of 53 of the first 287 tests of the CUDA build run on the CPU here
#   (2026-11-27).
# - A compiler with only a static libstdc++ (the GPU machines' /opt/gcc g++ 13: -print-file-name
#   finds no libstdc++.so) puts a second C++ runtime into each executable beside the libstdc++.so.6
#   LibTorch loads. Objects that cross between the two abort: a torch::jit stringstream freed a
#   std::locale of the other copy ("free(): invalid pointer" in every torch::serialize load, seen
#   on an H200, 2026-11-26). The system's shared one, from ldconfig, is linked instead.
if(NERFREG_WITH_TORCH)
  execute_process(COMMAND ${CMAKE_CXX_COMPILER} -print-file-name=libstdc++.so OUTPUT_VARIABLE nerfreg_stdcxx
                  OUTPUT_STRIP_TRAILING_WHITESPACE)
  if(NOT (IS_ABSOLUTE "${nerfreg_stdcxx}" AND EXISTS "${nerfreg_stdcxx}"))
    execute_process(COMMAND ldconfig -p OUTPUT_VARIABLE nerfreg_ldconfig)
    string(REGEX MATCH "libstdc\\+\\+\\.so\\.6 \\(libc6,x86-64\\) => ([^\n]+)" nerfreg_found "${nerfreg_ldconfig}")
    if(NOT CMAKE_MATCH_1 OR NOT EXISTS "${CMAKE_MATCH_1}")
      message(FATAL_ERROR "${CMAKE_CXX_COMPILER} has no libstdc++.so and ldconfig knows no libstdc++.so.6")
    endif()
    set(NERFREG_STDCXX_LIBRARY "${CMAKE_MATCH_1}")
    message(STATUS "nerfreg: ${CMAKE_CXX_COMPILER} links libstdc++ statically; ${NERFREG_STDCXX_LIBRARY} first")
  elseif(NOT TORCH_LIBRARY MATCHES "^/usr/lib/")  # not the system's (Debian's) LibTorch: a wheel's
    set(NERFREG_STDCXX_LIBRARY "${nerfreg_stdcxx}")
    message(STATUS "nerfreg: ${NERFREG_STDCXX_LIBRARY} first in every executable (a wheel's LibTorch)")
  endif()
endif()

# The CUDA build (NERFREG_CUDA): the .cu kernels need nvcc and a LibTorch built with CUDA (its
# TorchConfig brings CUDA::cudart and friends). A LibTorch taken from the PyPI wheel lacks the
# runtime libraries pip installs beside it (nvidia-* packages: cuSPARSELt, cuFile, NVSHMEM); the
# toolkit's own are found through rpath-link and the rest are left to the machine that runs the
# binaries (--allow-shlib-undefined), so the build links on a machine without them.
if(NERFREG_CUDA)
  if(NOT TORCH_CUDA_LIBRARIES AND NOT TARGET torch_cuda)
    message(FATAL_ERROR "NERFREG_CUDA=ON needs a LibTorch built with CUDA (Torch_DIR=${Torch_DIR})")
  endif()
  find_package(CUDAToolkit REQUIRED)
  add_link_options("LINKER:--allow-shlib-undefined" "LINKER:-rpath-link,${CUDAToolkit_LIBRARY_DIR}")
  if(EXISTS "${CUDAToolkit_LIBRARY_ROOT}/lib")
    add_link_options("LINKER:-rpath-link,${CUDAToolkit_LIBRARY_ROOT}/lib")
  endif()
endif()
