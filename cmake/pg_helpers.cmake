# Precompiled headers. Most sources include the standard library, Eigen, nlohmann::json and OpenCV's
# core, whose parsing was about half of a Release compile and a quarter of a sanitizer one. pg_pch
# parses them once and every library, tool, test and benchmark reuses that (GCC accepts it only
# where the compile flags agree: pg_precompile skips targets with flags of their own). Off for the
# fuzz and CUDA builds, which therefore also check that each source includes what it uses.
if(PG_PRECOMPILE_HEADERS AND (PG_BUILD_FUZZERS OR PG_WITH_CUDA))
  set(PG_PRECOMPILE_HEADERS OFF)
endif()
if(PG_PRECOMPILE_HEADERS)
  add_library(pg_pch_headers INTERFACE)
  target_link_libraries(pg_pch_headers INTERFACE Eigen3::Eigen nlohmann_json::nlohmann_json opencv_core)
  add_library(pg_pch STATIC ${PROJECT_SOURCE_DIR}/cmake/pg_pch.cpp)
  target_link_libraries(pg_pch PRIVATE pg_pch_headers)
  target_precompile_headers(pg_pch PRIVATE
    <algorithm> <array> <chrono> <cmath> <cstdint> <filesystem> <functional> <iostream> <map>
    <memory> <optional> <sstream> <string> <variant> <vector>
    <Eigen/Core> <Eigen/Geometry> <nlohmann/json.hpp> <opencv2/core.hpp>)
endif()

# pg_precompile(<target>): <target> reuses pg_pch (and may see its headers without including them).
function(pg_precompile target)
  if(PG_PRECOMPILE_HEADERS)
    target_precompile_headers(${target} REUSE_FROM pg_pch)
    target_link_libraries(${target} PRIVATE pg_pch_headers)
  endif()
endfunction()

# pg_add_module(<name> [OWN_FLAGS] DEPS <targets...> TEST_DEPS <targets...>)
#   One library per folder lib/pg/<name>: every *.cpp except *_test.cpp is a source.
#   Its *_test.cpp files become the test executable pg_<name>_tests.
#   OWN_FLAGS: the library adds compile flags of its own, so it cannot reuse the precompiled header.
function(pg_add_module name)
  cmake_parse_arguments(ARG "OWN_FLAGS" "" "DEPS;TEST_DEPS" ${ARGN})
  file(GLOB all_sources CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/*.cpp)
  set(sources "")
  set(tests "")
  foreach(f IN LISTS all_sources)
    if(f MATCHES "_test\\.cpp$")
      list(APPEND tests ${f})
    else()
      list(APPEND sources ${f})
    endif()
  endforeach()
  if(NOT sources)
    message(STATUS "pg: module ${name} has no sources yet; skipped")
    return()
  endif()
  add_library(pg_${name} STATIC ${sources})
  add_library(pg::${name} ALIAS pg_${name})
  target_include_directories(pg_${name} PUBLIC ${PROJECT_SOURCE_DIR}/lib ${PROJECT_BINARY_DIR}/generated)
  target_link_libraries(pg_${name} PUBLIC ${ARG_DEPS})
  if(NOT ARG_OWN_FLAGS)
    pg_precompile(pg_${name})
  endif()
  if(PG_BUILD_TESTS AND tests)
    pg_add_test(pg_${name}_tests SOURCES ${tests} DEPS pg_${name} ${ARG_TEST_DEPS})
  endif()
endfunction()

# pg_add_test(<name> SOURCES <files...> DEPS <targets...>)
function(pg_add_test name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} pg_testing GTest::gtest GTest::gtest_main)
  pg_precompile(${name})
  gtest_discover_tests(${name} DISCOVERY_MODE PRE_TEST
    PROPERTIES ENVIRONMENT "PG_BIN_DIR=${PROJECT_BINARY_DIR}/bin"
    DISCOVERY_TIMEOUT 60)
endfunction()

# pg_add_tool(<name> SOURCES <files...> DEPS <targets...>): an executable pg-<stage> in bin/.
function(pg_add_tool name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE pg_cli pg_aligned_allocation ${ARG_DEPS})
  pg_precompile(${name})
  set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/bin)
endfunction()
