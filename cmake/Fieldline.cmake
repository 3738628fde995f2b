# Small helpers shared by all folders.

# Adds every immediate subfolder of DIR that has a CMakeLists.txt, in name order, so a new
# service or library is one new folder and nothing else to edit.
function(fieldline_add_subdirectories dir)
  file(GLOB children RELATIVE ${PROJECT_SOURCE_DIR}/${dir} ${PROJECT_SOURCE_DIR}/${dir}/*)
  list(SORT children)
  foreach(child ${children})
    if(EXISTS ${PROJECT_SOURCE_DIR}/${dir}/${child}/CMakeLists.txt)
      add_subdirectory(${PROJECT_SOURCE_DIR}/${dir}/${child} ${PROJECT_BINARY_DIR}/${dir}/${child})
    endif()
  endforeach()
endfunction()

# fieldline_test(NAME SOURCES a.cpp b.cpp LIBS lib1 lib2 [LABELS unit] [ONE_PROCESS] [TEST_PREFIX p.])
# A GoogleTest executable whose cases are registered with CTest one by one, each run in its own
# process. ONE_PROCESS registers the executable as a single CTest test (named NAME) that runs all
# its cases in one process, for cases sharing an expensive suite fixture, such as the simulated
# camera's floor raster (~0.7 s to build), which would otherwise be rebuilt by every case's process.
function(fieldline_test name)
  cmake_parse_arguments(ARG "ONE_PROCESS" "TEST_PREFIX" "SOURCES;LIBS;LABELS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_LIBS} GTest::gtest GTest::gtest_main fieldline_root)
  if(NOT ARG_LABELS)
    set(ARG_LABELS unit)
  endif()
  if(ARG_ONE_PROCESS)
    add_test(NAME ${name} COMMAND ${name} WORKING_DIRECTORY ${PROJECT_SOURCE_DIR})
    set_tests_properties(${name} PROPERTIES LABELS "${ARG_LABELS}"
      ENVIRONMENT "FIELDLINE_ROOT=${PROJECT_SOURCE_DIR}")
    return()
  endif()
  # TEST_PREFIX: put before every case's name, so `ctest -R <prefix>` finds a group of suites
  # (ctest -R is case-sensitive; suites are CamelCase).
  set(prefix_args)
  if(ARG_TEST_PREFIX)
    set(prefix_args TEST_PREFIX "${ARG_TEST_PREFIX}")
  endif()
  gtest_discover_tests(${name} ${prefix_args}
    WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
    PROPERTIES LABELS "${ARG_LABELS}" ENVIRONMENT "FIELDLINE_ROOT=${PROJECT_SOURCE_DIR}"
    DISCOVERY_TIMEOUT 60)
endfunction()
