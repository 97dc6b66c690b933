# Helpers that give every coloc target the same compile settings.
include_guard(GLOBAL)

set(COLOC_WARNINGS -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wcast-align
                   -Woverloaded-virtual -Wnull-dereference -Wimplicit-fallthrough
                   # C++20 designated initializers leave defaulted members out on purpose.
                   -Wno-missing-field-initializers)

# coloc_library(NAME SOURCES ...): a static library of ours. Headers are included by their path
# from the repository root ("slam/core/se3.hpp"), as COLMAP does.
function(coloc_library name)
  add_library(${name} STATIC ${ARGN})
  add_library(coloc::${name} ALIAS ${name})
  coloc_apply_settings(${name})
  target_include_directories(${name} PUBLIC $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}>)
endfunction()

function(coloc_apply_settings target)
  target_compile_options(${target} PRIVATE ${COLOC_WARNINGS})
  if(COLOC_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
  target_compile_features(${target} PUBLIC cxx_std_20)
endfunction()

# coloc_test(NAME SOURCES ... LIBS ...): one GoogleTest executable registered with ctest.
# Tests find the shared real data through COLOC_DATA (default ../shared/data from the repo root).
function(coloc_test name)
  cmake_parse_arguments(ARG "" "" "SOURCES;LIBS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  coloc_apply_settings(${name})
  target_link_libraries(${name} PRIVATE ${ARG_LIBS} GTest::gtest GTest::gtest_main coloc_testing)
  include(GoogleTest)
  gtest_discover_tests(${name} DISCOVERY_TIMEOUT 60
                       PROPERTIES ENVIRONMENT "COLOC_SOURCE_DIR=${PROJECT_SOURCE_DIR}")
endfunction()

# coloc_benchmark(NAME SOURCES ... LIBS ...): a Google Benchmark program (not run by ctest).
function(coloc_benchmark name)
  if(NOT COLOC_BUILD_BENCHMARKS)
    return()
  endif()
  cmake_parse_arguments(ARG "" "" "SOURCES;LIBS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  coloc_apply_settings(${name})
  target_link_libraries(${name} PRIVATE ${ARG_LIBS} benchmark::benchmark benchmark::benchmark_main)
endfunction()
