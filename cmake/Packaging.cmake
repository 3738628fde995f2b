# The Debian package (scripts/package): the `robot` install component as fieldline_<version>_<arch>.deb,
# installed under /usr. Runtime dependencies are derived from the binaries by dpkg-shlibdeps
# (Debian package dpkg-dev), so they follow what is actually linked.
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME fieldline)
set(CPACK_PACKAGE_VENDOR "fieldline")
set(CPACK_PACKAGE_CONTACT "fieldline maintainers <fieldline@localhost>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY
    "Perception and localization for omni-directional RoboCup MSL robots")
set(CPACK_PACKAGE_DESCRIPTION
    "Camera, region tracking, feature recognition, fusion, motor bridge, pilot and team link as "
    "LCM processes, the launcher, systemd units, the live viewer, calibration, bus, replay and "
    "evaluation tools, and the simulator. See /usr/share/doc/fieldline/robot-install.md.")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_STRIP_FILES ON)
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_COMPONENTS_ALL robot)
# One package for the robot component, named like the project (not fieldline-robot).
set(CPACK_DEBIAN_ROBOT_PACKAGE_NAME fieldline)
set(CPACK_DEBIAN_ROBOT_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
# What dpkg-shlibdeps cannot see: the multicast route and buffers need iproute2 and procps only
# for setting up (documented), the units need systemd to be useful; lcm-spy needs Java.
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS "systemd")
set(CPACK_DEBIAN_PACKAGE_SUGGESTS "default-jre-headless, liblcm-java, libjchart2d-java, v4l-utils")
include(CPack)
