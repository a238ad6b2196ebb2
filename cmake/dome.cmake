# Boilerplate for dome's libraries, executables and tests.
#
#   dome_library(NAME core SOURCES a.cc b.cc DEPS PUBLIC x PRIVATE y)
#     -> target dome_core, include root ${CMAKE_SOURCE_DIR}/common so headers are
#        included as "core/a.h".
#   dome_executable(NAME dome SOURCES main.cc DEPS ...)
#   dome_test(NAME geometry_tsai SOURCES tsai_camera_test.cc DEPS dome_geometry)
#     -> gtest executable registered with ctest; DOME_SHARED_DIR and
#        DOME_SOURCE_DIR / DOME_BINARY_DIR are compiled in.

function(dome_library)
  cmake_parse_arguments(ARG "" "NAME" "SOURCES;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  set(target dome_${ARG_NAME})
  add_library(${target} STATIC ${ARG_SOURCES})
  target_include_directories(${target} PUBLIC ${CMAKE_SOURCE_DIR}/common)
  target_link_libraries(${target} PUBLIC ${ARG_PUBLIC_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
endfunction()

function(dome_executable)
  cmake_parse_arguments(ARG "" "NAME" "SOURCES;DEPS" ${ARGN})
  add_executable(${ARG_NAME} ${ARG_SOURCES})
  target_link_libraries(${ARG_NAME} PRIVATE ${ARG_DEPS})
endfunction()

function(dome_test)
  cmake_parse_arguments(ARG "" "NAME;TIMEOUT" "SOURCES;DEPS;LABELS" ${ARGN})
  set(target test_${ARG_NAME})
  add_executable(${target} ${ARG_SOURCES})
  target_link_libraries(${target} PRIVATE ${ARG_DEPS} GTest::gtest GTest::gtest_main ${OpenCV_LIBS})
  target_include_directories(${target} PRIVATE ${CMAKE_SOURCE_DIR}/tests)
  target_compile_definitions(${target} PRIVATE
    DOME_SHARED_DIR="${DOME_SHARED_DIR}"
    DOME_SOURCE_DIR="${CMAKE_SOURCE_DIR}"
    DOME_BINARY_DIR="${CMAKE_BINARY_DIR}")
  set_target_properties(${target} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/tests)
  include(GoogleTest)
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 300)
  endif()
  gtest_discover_tests(${target} DISCOVERY_TIMEOUT 60 PROPERTIES TIMEOUT ${ARG_TIMEOUT} LABELS "${ARG_LABELS}")
endfunction()
