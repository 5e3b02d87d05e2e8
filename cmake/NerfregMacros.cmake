# nerfreg_add_library(NAME SRCS ... [PUBLIC_LINK ...] [PRIVATE_LINK ...] [TORCH])
#   One static library per layer folder. TORCH: the sources include <torch/torch.h>; they reuse
#   one precompiled header (torch headers cost ~15 s per translation unit otherwise).
# nerfreg_add_test(NAME SRCS ... LINK ... [TORCH] [TIMEOUT S])
#   One GoogleTest binary per layer; every TEST becomes its own ctest entry, limited to S seconds
#   (default 180: a guard against hangs, not a speed check).

set(NERFREG_SRC_ROOT ${PROJECT_SOURCE_DIR}/src)

# The shared torch precompiled header, built once.
if(NERFREG_WITH_TORCH)
  add_library(nerfreg_torch_pch STATIC ${PROJECT_SOURCE_DIR}/cmake/torch_pch.cc)
  target_link_libraries(nerfreg_torch_pch PUBLIC nerfreg_torch)
  target_precompile_headers(nerfreg_torch_pch PRIVATE <torch/torch.h>)
endif()

function(nerfreg_use_torch_pch TARGET)
  target_precompile_headers(${TARGET} REUSE_FROM nerfreg_torch_pch)
endfunction()

# The libraries an executable must name before any other (see NerfregDependencies.cmake): the BLAS
# alternative (OpenBLAS), ahead of ATLAS's libf77blas that Ceres brings, and, against a LibTorch
# from PyTorch's wheels, the shared libstdc++, ahead of the std:: copies libtorch.so exports.
function(nerfreg_runtime_first TARGET)
  # One SHELL: option per library: CMake drops repeats of a plain option (a second --push-state).
  foreach(lib ${NERFREG_STDCXX_LIBRARY} ${NERFREG_BLAS_LIBRARY})
    target_link_options(${TARGET} BEFORE PRIVATE "SHELL:-Wl,--push-state,--no-as-needed ${lib} -Wl,--pop-state")
  endforeach()
endfunction()

function(nerfreg_add_library NAME)
  cmake_parse_arguments(A "TORCH" "" "SRCS;PUBLIC_LINK;PRIVATE_LINK" ${ARGN})
  add_library(${NAME} STATIC ${A_SRCS})
  target_include_directories(${NAME} PUBLIC ${NERFREG_SRC_ROOT})
  target_link_libraries(${NAME} PUBLIC ${A_PUBLIC_LINK} PRIVATE ${A_PRIVATE_LINK})
  target_compile_options(${NAME} PRIVATE -Wall -Wextra -Wno-unused-parameter)
  if(A_TORCH)
    target_link_libraries(${NAME} PUBLIC nerfreg_torch)
    nerfreg_use_torch_pch(${NAME})
  endif()
endfunction()

function(nerfreg_add_test NAME)
  if(NOT NERFREG_BUILD_TESTS)
    return()
  endif()
  cmake_parse_arguments(A "TORCH" "TIMEOUT" "SRCS;LINK" ${ARGN})
  if(NOT A_TIMEOUT)
    set(A_TIMEOUT 180)
  endif()
  add_executable(${NAME} ${A_SRCS})
  nerfreg_runtime_first(${NAME})
  target_link_libraries(${NAME} PRIVATE ${A_LINK} nerfreg_test_main)
  if(A_TORCH)
    target_link_libraries(${NAME} PRIVATE nerfreg_torch)
    nerfreg_use_torch_pch(${NAME})
  endif()
  # Tests find shipped assets and the built binary through these.
  target_compile_definitions(${NAME} PRIVATE
    NERFREG_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
    NERFREG_BINARY="${PROJECT_BINARY_DIR}/nerfreg")
  # The threading environment nerfreg's main() sets for itself (see exe/main.cc).
  # The CUDA build lists its tests when ctest runs, not after linking: `make cuda` links on machines
  # that lack the CUDA runtime libraries the binaries need to start.
  if(NERFREG_CUDA)
    set(discovery_mode PRE_TEST)
  else()
    set(discovery_mode POST_BUILD)
  endif()
  gtest_discover_tests(${NAME} DISCOVERY_TIMEOUT 120 DISCOVERY_MODE ${discovery_mode}
    PROPERTIES TIMEOUT ${A_TIMEOUT} ENVIRONMENT "OMP_WAIT_POLICY=PASSIVE;OPENBLAS_NUM_THREADS=1")
endfunction()

# nerfreg_test_costs(TEST SECONDS [TEST SECONDS ...]): how long the folder's slowest discovered tests
# take (seconds on an idle 2-core machine), as ctest's COST. `ctest -j` starts the costliest tests
# first; a clean checkout (CI) has no timings of its own (Testing/Temporary/CTestCostData.txt), so
# without these it starts them in listed order and a 3-minute test can begin last, with one core
# idle beside it. The tests exist only once gtest_discover_tests has run, so the properties are set
# from an include file ctest reads after the discovered tests' own. Call after the folder's tests.
function(nerfreg_test_costs)
  if(NOT NERFREG_BUILD_TESTS)
    return()
  endif()
  set(file ${CMAKE_CURRENT_BINARY_DIR}/nerfreg_test_costs.cmake)
  set(lines "")
  while(ARGN)
    list(POP_FRONT ARGN test seconds)
    string(APPEND lines "set_tests_properties(\"${test}\" PROPERTIES COST ${seconds})\n")
  endwhile()
  file(WRITE ${file} "${lines}")
  set_property(DIRECTORY APPEND PROPERTY TEST_INCLUDE_FILES ${file})
endfunction()

# nerfreg_test_timeout(TEST SECONDS): a longer ctest TIMEOUT for one discovered test of the folder
# than its target's. Call after the folder's nerfreg_test_costs (it shares that include file).
function(nerfreg_test_timeout TEST SECONDS)
  if(NOT NERFREG_BUILD_TESTS)
    return()
  endif()
  file(APPEND ${CMAKE_CURRENT_BINARY_DIR}/nerfreg_test_costs.cmake
       "set_tests_properties(\"${TEST}\" PROPERTIES TIMEOUT ${SECONDS})\n")
endfunction()
