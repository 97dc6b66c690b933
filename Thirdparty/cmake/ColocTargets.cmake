# Helpers that give every coloc target the same compile settings.
include_guard(GLOBAL)

set(COLOC_WARNINGS -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wcast-align
                   -Woverloaded-virtual -Wnull-dereference -Wimplicit-fallthrough
                   # C++20 designated initializers leave defaulted members out on purpose.
                   -Wno-missing-field-initializers)
# A unity build (CMAKE_UNITY_BUILD: a fresh scripts/build tree) #includes each source into a batch
# file; GCC then takes a class holding a type of that source's anonymous namespace for a header
# that leaks an internal type, which it is not.
if(CMAKE_UNITY_BUILD)
  list(APPEND COLOC_WARNINGS -Wno-subobject-linkage)
endif()

# coloc_library(NAME SOURCES ...): a static library of ours. Headers are included by their path
# from the repository root ("slam/core/se3.hpp"), as COLMAP does; installed, from
# include/coloc. Libraries outside tests/ are installed and exported (coloc_export).
function(coloc_library name)
  add_library(${name} STATIC ${ARGN})
  add_library(coloc::${name} ALIAS ${name})
  coloc_apply_settings(${name})
  coloc_public_includes(${name})
  string(FIND "${CMAKE_CURRENT_SOURCE_DIR}/" "${PROJECT_SOURCE_DIR}/tests/" in_tests)
  if(NOT in_tests EQUAL 0)
    coloc_export(${name})
  endif()
endfunction()

# coloc_public_includes(TARGET): the include root for users, in the build and installed.
function(coloc_public_includes target)
  target_include_directories(${target} PUBLIC $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}>
                                              $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}/coloc>)
endfunction()

# coloc_export(TARGET...): installed with the exported CMake package (find_package(coloc)
# gives coloc::TARGET; ColocInstall.cmake writes the rules once every target is known).
function(coloc_export)
  set_property(GLOBAL APPEND PROPERTY COLOC_EXPORTED_TARGETS ${ARGN})
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

# coloc_find_python3(): sets the cache variable COLOC_PYTHON3 to the python3 that the CLI's
# plots and the Python checks run with. Debian's python3 with python3-numpy and
# python3-matplotlib is /usr/bin/python3 (a pyenv python earlier on PATH may lack them).
function(coloc_find_python3)
  find_program(COLOC_PYTHON3 python3 PATHS /usr/bin NO_DEFAULT_PATH)
  if(NOT COLOC_PYTHON3)
    find_program(COLOC_PYTHON3 python3)
  endif()
endfunction()

# coloc_cli_test(name script.py [args...]): a Python check that drives the `coloc` binary
# (passed as --coloc PATH, then args). Exit 77 = skipped (data missing).
function(coloc_cli_test name script)
  coloc_find_python3()
  if(NOT COLOC_PYTHON3 OR NOT TARGET coloc)
    return()
  endif()
  add_test(NAME ${name}
           COMMAND ${COLOC_PYTHON3} ${CMAKE_CURRENT_SOURCE_DIR}/${script}
                   --coloc $<TARGET_FILE:coloc> ${ARGN})
  set_tests_properties(${name} PROPERTIES SKIP_RETURN_CODE 77)
endfunction()

# The build tree's copy of what is installed under share/coloc (COLOC_STAGE_DIR), so the CLI
# finds its data the same way in both: coloc_stage_data(TARGET SOURCE DEST [SOURCE DEST]...)
# copies each SOURCE to COLOC_STAGE_DIR/DEST whenever it changes.
set(COLOC_STAGE_DIR ${CMAKE_BINARY_DIR}/share/coloc)
function(coloc_stage_data target)
  set(outputs "")
  while(ARGN)
    list(POP_FRONT ARGN source dest)
    list(APPEND outputs ${COLOC_STAGE_DIR}/${dest})
    add_custom_command(OUTPUT ${COLOC_STAGE_DIR}/${dest}
                       COMMAND ${CMAKE_COMMAND} -E copy ${source} ${COLOC_STAGE_DIR}/${dest}
                       DEPENDS ${source} VERBATIM)
  endwhile()
  add_custom_target(${target} ALL DEPENDS ${outputs})
endfunction()
