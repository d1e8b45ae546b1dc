# The Debian package (CPack DEB, CMake's own; nothing downloaded). scripts/package.sh builds
# it; tests/package/package_test.sh installs it into a scratch root and checks it
# (docs/install.md). The package always installs under /usr with the configuration in /etc,
# whatever CMAKE_INSTALL_PREFIX the build tree was configured with: CPack runs the install
# with the prefix /usr and DESTDIR set to its staging folder, and cmake/install_templates.cmake
# writes the unit's and the config's paths for that prefix.
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME ndsid)
set(CPACK_PACKAGE_VERSION "${PROJECT_VERSION}")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "online identification of lateral vehicle dynamics from CAN")
set(CPACK_PACKAGE_DESCRIPTION
"ndsidd reads a vehicle's CAN bus (SocketCAN) and identifies the single-track
model's parameters and the self-steering gradient from naturalistic driving,
with validity and uncertainty on every estimate. It publishes over LCM and runs
as a hardened systemd service. ndsid is the desk tool: decode, replay, compare,
diagnose, study and simulate on candump logs. Includes the LCM message types
(C++ headers, Java jar, Python module), an example vehicle configuration for
can0 with its DBC, and ndsid-lcm-spy (lcm-spy for Java 17).")
set(NDSID_DEB_MAINTAINER "ndsid maintainers <ndsid@localhost>" CACHE STRING
    "Maintainer: of the Debian package (name <address>); lintian rejects the default's address")
set(CPACK_PACKAGE_CONTACT "${NDSID_DEB_MAINTAINER}")
set(CPACK_DEBIAN_PACKAGE_MAINTAINER "${NDSID_DEB_MAINTAINER}")
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
set(CPACK_DEBIAN_PACKAGE_RELEASE 1)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)          # ndsid_<version>-1_<arch>.deb
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_INSTALL_PREFIX /usr)                   # the prefix of the DESTDIR install below
set(CPACK_SET_DESTDIR ON)                        # absolute destinations (/etc/ndsid) go into the package
set(CPACK_STRIP_FILES ON)                        # RelWithDebInfo binaries without their debug info
# Depends: from the binaries' ELF NEEDED entries (dpkg-shlibdeps against the Debian 12 system
# the package is built on): libceres3, liblcm1, libyaml-cpp0.7, libspdlog1.10, libfmt9,
# libsystemd0, zlib1g, libstdc++6, libc6, ...
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
# The arm64 cross build (cmake/toolchain-arm64.cmake): the package's architecture is the target's,
# not the host's (`dpkg --print-architecture`). dpkg-shlibdeps cannot see the arm64 libraries
# (they are in the sysroot, which has no dpkg database): scripts/package.sh --arch arm64 gives
# Depends on cpack's command line, from the binaries' NEEDED entries (scripts/deb_depends.sh).
if(CMAKE_CROSSCOMPILING AND CMAKE_SYSTEM_PROCESSOR STREQUAL "aarch64")
  set(CPACK_DEBIAN_PACKAGE_ARCHITECTURE arm64)
  set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS OFF)
endif()
# Not needed by ndsidd: ndsid-lcm-spy (Java, lcm.jar, jchart2d), CAN tools, the Python
# module's `lcm` (pip install lcm: Debian 12 has no python3-lcm), python3-venv for `ndsid-foxglove --setup`.
set(CPACK_DEBIAN_PACKAGE_SUGGESTS "liblcm-java, libjchart2d-java, default-jre, liblcm-bin, can-utils, python3, python3-venv")
# Maintainer scripts (daemon-reload, stop on removal, purge of the learned state) and the
# conffile list: /etc/ndsid/vehicle.yaml is the administrator's, dpkg keeps their edits.
set(ndsid_control_dir "${CMAKE_BINARY_DIR}/debian-control")
foreach(f conffiles postinst prerm postrm)
  configure_file("${CMAKE_SOURCE_DIR}/cmake/debian/${f}" "${ndsid_control_dir}/${f}" @ONLY
                 FILE_PERMISSIONS OWNER_READ OWNER_WRITE OWNER_EXECUTE GROUP_READ GROUP_EXECUTE WORLD_READ WORLD_EXECUTE)
  list(APPEND CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA "${ndsid_control_dir}/${f}")
endforeach()
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)  # conffiles 0644, scripts 0755
# /usr/share/doc/ndsid/changelog.Debian.gz (Debian policy 12.7), dated at configure time
# (SOURCE_DATE_EPOCH when set), compressed without a time stamp so rebuilds are identical.
string(TIMESTAMP NDSID_CHANGELOG_DATE "%a, %d %b %Y %H:%M:%S +0000" UTC)
configure_file("${CMAKE_SOURCE_DIR}/cmake/debian/changelog.Debian" "${ndsid_control_dir}/changelog.Debian" @ONLY)
execute_process(COMMAND gzip -9nc "${ndsid_control_dir}/changelog.Debian"
                OUTPUT_FILE "${ndsid_control_dir}/changelog.Debian.gz" RESULT_VARIABLE ndsid_gzip_rc)
if(NOT ndsid_gzip_rc EQUAL 0)
  message(FATAL_ERROR "ndsid: gzip of changelog.Debian failed (${ndsid_gzip_rc})")
endif()
install(FILES "${ndsid_control_dir}/changelog.Debian.gz" DESTINATION "${CMAKE_INSTALL_DOCDIR}")
set(CPACK_PACKAGE_DIRECTORY "${CMAKE_BINARY_DIR}/dist")
set(CPACK_PRE_BUILD_SCRIPTS "${CMAKE_SOURCE_DIR}/cmake/package_fix_modes.cmake")  # folders 0755 whatever the umask
include(CPack)
