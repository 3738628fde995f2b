# Debian's LCM 1.3.1 ships no CMake config: find the library, headers and lcm-gen ourselves.
# Provides LCM::lcm, LCM_GEN_EXECUTABLE and LCM_JAR.
find_path(LCM_INCLUDE_DIR lcm/lcm-cpp.hpp)
find_library(LCM_LIBRARY NAMES lcm)
find_program(LCM_GEN_EXECUTABLE lcm-gen)
find_file(LCM_JAR lcm.jar PATHS /usr/share/java /usr/local/share/java)
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(LCM
  REQUIRED_VARS LCM_LIBRARY LCM_INCLUDE_DIR LCM_GEN_EXECUTABLE
  FAIL_MESSAGE "LCM not found: run scripts/setup (apt packages liblcm-dev liblcm-bin liblcm-java)")
if(LCM_FOUND AND NOT TARGET LCM::lcm)
  add_library(LCM::lcm UNKNOWN IMPORTED)
  set_target_properties(LCM::lcm PROPERTIES
    IMPORTED_LOCATION "${LCM_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${LCM_INCLUDE_DIR}")
endif()
mark_as_advanced(LCM_INCLUDE_DIR LCM_LIBRARY LCM_GEN_EXECUTABLE LCM_JAR)
