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

# Precompiled headers (option FIELDLINE_PCH) of the test executables: GoogleTest, Eigen/Core,
# yaml-cpp and the common standard headers (cmake/pch/test.hpp) are parsed once per build instead
# of once per test file. One donor target compiles them; every fieldline_test() executable reuses
# the result (REUSE_FROM), so it shares the donor's flags: only headers whose meaning does not
# depend on a target's own definitions (FMT_SHARED, SPDLOG_*, ...) go in, and -Winvalid-pch (with
# -Werror) fails a mismatch loudly. FIELDLINE_PCH=OFF builds without (e.g. to check that every test
# file includes what it uses).
function(fieldline_precompiled_header_targets)
  if(NOT FIELDLINE_PCH OR NOT TARGET GTest::gtest)
    return()
  endif()
  add_library(fieldline_test_pch OBJECT ${PROJECT_SOURCE_DIR}/cmake/pch/pch.cpp)
  target_link_libraries(fieldline_test_pch PRIVATE fieldline_root Eigen3::Eigen yaml-cpp
                                                   GTest::gtest)
  target_precompile_headers(fieldline_test_pch PRIVATE ${PROJECT_SOURCE_DIR}/cmake/pch/test.hpp)
  fieldline_test_debug_info(fieldline_test_pch)
  fieldline_test_optimisation(fieldline_test_pch)
endfunction()

# The test executables carry no debug information unless FIELDLINE_TEST_DEBUG_INFO is on: their
# own files are compiled without it and the line tables of the libraries they link are left out
# (--strip-debug keeps the symbols). Two thirds of a test executable were debug sections, and
# the test executables most of the build tree. A failing test to debug: -DFIELDLINE_TEST_DEBUG_INFO=ON.
function(fieldline_test_debug_info target)
  if(NOT FIELDLINE_TEST_DEBUG_INFO)
    target_compile_options(${target} PRIVATE -g0)
    get_target_property(type ${target} TYPE)
    if(type STREQUAL "EXECUTABLE")
      target_link_options(${target} PRIVATE -Wl,--strip-debug)
    endif()
  endif()
endfunction()

# fieldline_use_test_precompiled_header(TARGET): TARGET's C++ files start from the test one.
function(fieldline_use_test_precompiled_header target)
  if(TARGET fieldline_test_pch)
    target_precompile_headers(${target} REUSE_FROM fieldline_test_pch)
  endif()
endfunction()

# How the test executables are compiled. Most of a test file's compile time is parsing the same
# headers (GoogleTest, Eigen, yaml-cpp, CLI11, Asio: 1-3 CPU-s each per file), so each folder of
# tests/unit is one executable (or a few: see fieldline_test) built as a unity build: up to
# FIELDLINE_TEST_UNITY_BATCH of its files are compiled as one unit, and the headers are parsed
# once per unit (docs/log/2026-12-06-build.md, "Session 6 (tests)"). Two files of one executable
# therefore must not define the same name at file scope, even in an anonymous namespace: a file's
# local helpers live in a namespace named after the file. FIELDLINE_TEST_UNITY=OFF compiles every
# file alone (e.g. to check that each test file includes what it uses).
option(FIELDLINE_TEST_UNITY "Test executables as unity builds (cmake/Fieldline.cmake)" ON)
# 16 (8 before session 14): the largest test executable (fusion_test, 14 files) is one unit, and
# a group (fieldline_test GROUP) of 28 files two: fusion_test 47.5 -> 40.0 CPU-s, feature
# recognition's 11 files 17.7 -> 13.5 (docs/log/2026-12-07-session14-build.md); a changed test
# file recompiles up to 16 files (fusion_test's one unit: 40 CPU-s at load 12-16).
set(FIELDLINE_TEST_UNITY_BATCH 16 CACHE STRING "Test files per unity unit (cmake/Fieldline.cmake)")
# The test files' own code is compiled at FIELDLINE_TEST_OPT_LEVEL (the libraries they link keep
# the build type's -O2): it is mostly set-up and checks. -Og compiled two units alone about a fifth
# faster than -O1, but a whole build's test units took the same (396 against 398 job-s, back to
# back; docs/log/2026-12-07-build.md, "Session 8 (lead)"); -O1 takes about a fifth less than -O2
# (docs/log/2026-12-06-build.md); -O0 is no faster
# than -O1 (every inline function is emitted). The slow cases' work is in the -O2 libraries.
# With the build type's level (empty) g++ 12 reports a false -Wmaybe-uninitialized (std::optional,
# in tests/unit/fusion/odometry_layer_test.cpp) in fusion_test's unity unit, so that needs
# FIELDLINE_WERROR=OFF or FIELDLINE_TEST_UNITY=OFF.
set(FIELDLINE_TEST_OPT_LEVEL -Og CACHE STRING "Optimisation of the test files' own code")

# fieldline_optimisation_level(TARGET LEVEL): TARGET's own code at LEVEL (e.g. -O1) in the optimised
# build types; an empty LEVEL leaves the build type's.
function(fieldline_optimisation_level target level)
  if(level)
    target_compile_options(${target} PRIVATE $<$<CONFIG:RelWithDebInfo,Release>:${level}>)
  endif()
endfunction()

function(fieldline_test_optimisation target)
  fieldline_optimisation_level(${target} "${FIELDLINE_TEST_OPT_LEVEL}")
endfunction()

# fieldline_test(NAME SOURCES a.cpp b.cpp LIBS lib1 lib2 [LABELS unit] [ONE_PROCESS] [TEST_PREFIX p.])
# A GoogleTest executable whose cases are registered with CTest one by one, each run in its own
# process. ONE_PROCESS registers the executable as a single CTest test (named NAME) that runs all
# its cases in one process, for cases sharing an expensive suite fixture, such as the simulated
# camera's floor raster (~0.7 s to build), which would otherwise be rebuilt by every case's process.
# A folder puts all its files whose cases are registered alike (the same LABELS and TEST_PREFIX,
# not ONE_PROCESS) in one executable.
#
# GROUP g: the files go into the test executable g that fieldline_test_groups() adds (after every
# folder of tests/unit) instead of an executable NAME of their own; the ctest names of the cases
# are the same (Suite.Case), each still a process of its own. For small test executables of one
# or two files: each costs a unit that parses GoogleTest, Eigen and the standard library again
# (about 3 CPU-s) and a link (docs/build.md). Only with the default label, no TEST_PREFIX and not
# ONE_PROCESS, so a group's cases are registered exactly as its members' were; the members' files
# obey the unity rule across folders (file-local names in a namespace named after the file).
function(fieldline_test name)
  cmake_parse_arguments(ARG "ONE_PROCESS" "TEST_PREFIX;GROUP" "SOURCES;LIBS;LABELS" ${ARGN})
  if(ARG_GROUP)
    if(ARG_ONE_PROCESS OR ARG_TEST_PREFIX OR ARG_LABELS)
      message(FATAL_ERROR "fieldline_test(${name}): GROUP only without ONE_PROCESS, TEST_PREFIX and LABELS")
    endif()
    list(TRANSFORM ARG_SOURCES PREPEND ${CMAKE_CURRENT_SOURCE_DIR}/)
    set_property(GLOBAL APPEND PROPERTY FIELDLINE_TEST_GROUPS ${ARG_GROUP})
    set_property(GLOBAL APPEND PROPERTY FIELDLINE_TEST_GROUP_${ARG_GROUP}_SOURCES ${ARG_SOURCES})
    set_property(GLOBAL APPEND PROPERTY FIELDLINE_TEST_GROUP_${ARG_GROUP}_LIBS ${ARG_LIBS})
    set_property(GLOBAL APPEND PROPERTY FIELDLINE_TEST_GROUP_${ARG_GROUP}_MEMBERS ${name})
    return()
  endif()
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_LIBS} GTest::gtest GTest::gtest_main fieldline_root)
  fieldline_use_test_precompiled_header(${name})
  fieldline_test_debug_info(${name})
  if(FIELDLINE_TEST_UNITY)
    set_target_properties(${name} PROPERTIES UNITY_BUILD ON
                                             UNITY_BUILD_BATCH_SIZE ${FIELDLINE_TEST_UNITY_BATCH})
  endif()
  fieldline_test_optimisation(${name})
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
  # A case that calls GTEST_SKIP() exits 0: without the expression ctest would count it as passed
  # (one ctest test per case here; a ONE_PROCESS executable's skipped case must not mark it all).
  gtest_discover_tests(${name} ${prefix_args}
    WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
    PROPERTIES LABELS "${ARG_LABELS}" ENVIRONMENT "FIELDLINE_ROOT=${PROJECT_SOURCE_DIR}"
               SKIP_REGULAR_EXPRESSION "\\[  SKIPPED \\]"
    DISCOVERY_TIMEOUT 60)
endfunction()

# The executables of fieldline_test(... GROUP g): one per group, with every member's files and
# libraries (in the order the folders were added: name order).
function(fieldline_test_groups)
  get_property(groups GLOBAL PROPERTY FIELDLINE_TEST_GROUPS)
  list(REMOVE_DUPLICATES groups)
  foreach(group ${groups})
    get_property(sources GLOBAL PROPERTY FIELDLINE_TEST_GROUP_${group}_SOURCES)
    get_property(libs GLOBAL PROPERTY FIELDLINE_TEST_GROUP_${group}_LIBS)
    list(REMOVE_DUPLICATES libs)
    fieldline_test(${group} SOURCES ${sources} LIBS ${libs})
  endforeach()
endfunction()

# Installation (docs/robot-install.md). Executables go to <prefix>/bin, data to
# <prefix>/share/fieldline. Two components:
#   robot  what a robot and its team use (services, launcher, viewer, calibration, bus tools,
#          replay and evaluation); the default, and the .deb `scripts/package` builds;
#   dev    test, benchmark and attack tools: `cmake --install build --component dev` only.
# Every executable outside tests/ must be given to fieldline_install (ctest install_classified).
include(GNUInstallDirs)
set(FIELDLINE_INSTALL_DATADIR ${CMAKE_INSTALL_DATADIR}/fieldline)
set(CMAKE_INSTALL_DEFAULT_COMPONENT_NAME robot)

# fieldline_install(TARGETS t1 t2 ... [DEV])
function(fieldline_install)
  cmake_parse_arguments(ARG "DEV" "" "TARGETS" ${ARGN})
  if(ARG_DEV)
    install(TARGETS ${ARG_TARGETS} RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT dev
            EXCLUDE_FROM_ALL)
    set_target_properties(${ARG_TARGETS} PROPERTIES FIELDLINE_INSTALL_COMPONENT dev)
  else()
    install(TARGETS ${ARG_TARGETS} RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT robot)
    set_target_properties(${ARG_TARGETS} PROPERTIES FIELDLINE_INSTALL_COMPONENT robot)
  endif()
endfunction()

# fieldline_data_directory(DIR AS NAME [DEV] [NO_INSTALL])
# The folder DIR (relative to the calling CMakeLists.txt) is installed as
# <prefix>/share/fieldline/NAME, and the build tree gets build/share/fieldline/NAME, a symlink to
# it, so a binary finds its data at <its folder>/../share/fieldline both ways
# (common/config dataDirectory()). NO_INSTALL: the symlink only (test data).
function(fieldline_data_directory dir)
  cmake_parse_arguments(ARG "DEV;NO_INSTALL" "AS" "" ${ARGN})
  get_filename_component(source ${dir} ABSOLUTE BASE_DIR ${CMAKE_CURRENT_SOURCE_DIR})
  set(link ${PROJECT_BINARY_DIR}/${FIELDLINE_INSTALL_DATADIR}/${ARG_AS})
  get_filename_component(parent ${link} DIRECTORY)
  file(MAKE_DIRECTORY ${parent})
  if(IS_SYMLINK ${link} OR EXISTS ${link})
    file(REMOVE ${link})
  endif()
  file(CREATE_LINK ${source} ${link} SYMBOLIC)
  if(ARG_NO_INSTALL)
    return()
  endif()
  if(ARG_DEV)
    install(DIRECTORY ${source}/ DESTINATION ${FIELDLINE_INSTALL_DATADIR}/${ARG_AS} COMPONENT dev
            EXCLUDE_FROM_ALL)
  else()
    install(DIRECTORY ${source}/ DESTINATION ${FIELDLINE_INSTALL_DATADIR}/${ARG_AS}
            COMPONENT robot)
  endif()
endfunction()

# fieldline_targets_under(DIR OUT): every target defined in DIR and its subfolders, into OUT.
function(fieldline_targets_under dir out)
  get_property(found DIRECTORY ${dir} PROPERTY BUILDSYSTEM_TARGETS)
  get_property(subdirs DIRECTORY ${dir} PROPERTY SUBDIRECTORIES)
  foreach(sub ${subdirs})
    fieldline_targets_under(${sub} sub_found)
    list(APPEND found ${sub_found})
  endforeach()
  set(${out} ${found} PARENT_SCOPE)
endfunction()

# Every executable target under DIR (recursively) that is outside tests/ and was not given to
# fieldline_install, into OUT.
function(fieldline_unclassified_executables dir out)
  set(found)
  fieldline_targets_under(${dir} targets)
  foreach(t ${targets})
    get_target_property(type ${t} TYPE)
    get_target_property(component ${t} FIELDLINE_INSTALL_COMPONENT)
    get_target_property(source_dir ${t} SOURCE_DIR)
    if(type STREQUAL "EXECUTABLE" AND NOT component AND NOT source_dir MATCHES
                                                        "^${PROJECT_SOURCE_DIR}/tests(/|$)")
      list(APPEND found ${t})
    endif()
  endforeach()
  set(${out} ${found} PARENT_SCOPE)
endfunction()

# Code that is not on the robot's hot path is compiled at FIELDLINE_TOOL_OPT_LEVEL: the tools
# (tools/: calibration, evaluation, the viewer, the pictures, the launcher) and the command-line
# front end (common/cli, run once at a program's start); the libraries of common/, services/ and
# teamcomm/ that the robot runs keep the build type's -O2. -O1 compiles mirror calibration's first
# unit alone in a third less CPU time, the tools of a whole build in 6 % less (357 -> 334 job-s,
# docs/log/2026-12-07-build.md, "Session 8 (build)" and "(lead)"); on x86-64
# without -ffast-math both levels give the same floating-point results. Empty: the build type's
# level.
set(FIELDLINE_TOOL_OPT_LEVEL -O1 CACHE STRING "Optimisation of the tools' own code (tools/)")

function(fieldline_cold_code target)
  fieldline_optimisation_level(${target} "${FIELDLINE_TOOL_OPT_LEVEL}")
endfunction()

# fieldline_tool_optimisation(DIR): fieldline_cold_code for every library and executable under DIR
# (recursively), except targets with the property FIELDLINE_KEEP_OPT_LEVEL.
function(fieldline_tool_optimisation dir)
  fieldline_targets_under(${dir} targets)
  foreach(t ${targets})
    get_target_property(type ${t} TYPE)
    get_target_property(keep ${t} FIELDLINE_KEEP_OPT_LEVEL)
    if(type MATCHES "^(STATIC_LIBRARY|OBJECT_LIBRARY|SHARED_LIBRARY|EXECUTABLE)$" AND NOT keep)
      fieldline_cold_code(${t})
    endif()
  endforeach()
endfunction()

# fieldline_unity_build(DIR BATCH_SIZE n): every library and executable under DIR (recursively)
# with two or more C++ files is compiled as unity units of up to n files each (CMake's
# UNITY_BUILD): the headers the files share are parsed, and their inline functions compiled,
# once per unit instead of once per file. Single-file targets (most mains) are left as they are,
# so their objects stay the same. Touching one file recompiles its unit: n bounds that rebuild.
# A file that cannot share a unit (file-local names that clash with another file's):
# set_source_files_properties(f.cpp PROPERTIES SKIP_UNITY_BUILD_INCLUSION ON) in its
# CMakeLists.txt, with the reason; a whole target: set_target_properties(t PROPERTIES
# FIELDLINE_NO_UNITY ON).
function(fieldline_unity_build dir)
  cmake_parse_arguments(ARG "" "BATCH_SIZE" "" ${ARGN})
  fieldline_targets_under(${dir} targets)
  foreach(t ${targets})
    get_target_property(type ${t} TYPE)
    if(NOT type MATCHES "^(STATIC_LIBRARY|OBJECT_LIBRARY|EXECUTABLE)$")
      continue()
    endif()
    get_target_property(no_unity ${t} FIELDLINE_NO_UNITY)
    if(no_unity)
      continue()
    endif()
    get_target_property(sources ${t} SOURCES)
    list(FILTER sources INCLUDE REGEX "\\.cpp$")
    list(LENGTH sources count)
    if(count GREATER 1)
      set_target_properties(${t} PROPERTIES UNITY_BUILD ON UNITY_BUILD_BATCH_SIZE ${ARG_BATCH_SIZE})
    endif()
  endforeach()
endfunction()
