# Install rules (included by the top-level CMakeLists.txt). With the prefix /usr (the Debian
# package, scripts/package.sh, or `cmake --install build --prefix /usr`):
#   /usr/sbin/ndsidd, /usr/bin/ndsid                     (src/service, src/desk CMakeLists.txt)
#   /usr/bin/ndsid-lcm-spy                               (scripts/ndsid-lcm-spy: lcm-spy for Java 17)
#   /usr/bin/ndsid-foxglove, /usr/share/ndsid/foxglove/  (the Foxglove bridge, its layout, its pins)
#   /usr/lib/systemd/system/ndsidd.service               (paths rewritten to the prefix)
#   /etc/ndsid/vehicle.yaml                              (config/example_vehicle.yaml on socketcan can0)
#   /usr/share/ndsid/dbc/ndsid_example.dbc               (referenced by the installed config)
#   /usr/share/ndsid/systemd/80-can0.network, 80-vcan0.* (examples for /etc/systemd/network)
#   /usr/share/ndsid/java/ndsid_lcmtypes.jar, lcmtypes/  (lcmtypes/CMakeLists.txt)
#   /usr/include/ndsid/*.hpp, /usr/lib/python3/dist-packages/ndsid/  (LCM types, C++ and Python)
#   /usr/share/doc/ndsid/*.md
#
# The paths written INTO installed files (the unit's ExecStart, the config's dbc) are computed
# when installing, from the prefix in force then: `cmake --install build --prefix /usr` after a
# configure with the default /usr/local must give /usr/sbin/ndsidd in the unit, not
# /usr/local/sbin/ndsidd (that unit exited 78). cmake/install_templates.cmake does it.
set(NDSID_SYSTEMD_UNIT_DIR "" CACHE PATH "Where ndsidd.service is installed (empty: <install prefix>/lib/systemd/system)")
unset(NDSID_UNIT_DIR CACHE)  # its old default froze the configure-time prefix

install(CODE "
  set(NDSID_SOURCE_DIR [[${CMAKE_SOURCE_DIR}]])
  set(NDSID_STAGING_DIR [[${CMAKE_BINARY_DIR}/install-templates]])
  set(NDSID_UNIT_DIR [[${NDSID_SYSTEMD_UNIT_DIR}]])
  set(NDSID_SBINDIR [[${CMAKE_INSTALL_SBINDIR}]])
  set(NDSID_SYSCONFDIR [[${CMAKE_INSTALL_SYSCONFDIR}]])
  set(NDSID_DATADIR [[${CMAKE_INSTALL_DATADIR}]])
  set(NDSID_DOCDIR [[${CMAKE_INSTALL_DOCDIR}]])
  include([[${CMAKE_SOURCE_DIR}/cmake/install_templates.cmake]])
")

install(FILES "${CMAKE_SOURCE_DIR}/dbc/ndsid_example.dbc" DESTINATION "${CMAKE_INSTALL_DATADIR}/ndsid/dbc")
install(FILES "${CMAKE_SOURCE_DIR}/systemd/80-can0.network" "${CMAKE_SOURCE_DIR}/systemd/80-vcan0.netdev"
              "${CMAKE_SOURCE_DIR}/systemd/80-vcan0.network"
        DESTINATION "${CMAKE_INSTALL_DATADIR}/ndsid/systemd")
install(PROGRAMS "${CMAKE_SOURCE_DIR}/replay/vcan_replay.sh" DESTINATION "${CMAKE_INSTALL_DATADIR}/ndsid/replay" OPTIONAL)
install(PROGRAMS "${CMAKE_SOURCE_DIR}/scripts/ndsid-lcm-spy" DESTINATION "${CMAKE_INSTALL_BINDIR}")
# The Foxglove bridge: its launcher, the script, the layout, and the two pins it needs from
# requirements.txt (`ndsid-foxglove --setup` installs them into a venv: Debian 12 has neither).
install(PROGRAMS "${CMAKE_SOURCE_DIR}/scripts/ndsid-foxglove" DESTINATION "${CMAKE_INSTALL_BINDIR}")
file(STRINGS "${CMAKE_SOURCE_DIR}/requirements.txt" ndsid_foxglove_pins REGEX "^(foxglove-sdk|lcm)==")
list(TRANSFORM ndsid_foxglove_pins REPLACE " *#.*" "")
list(JOIN ndsid_foxglove_pins "\n" ndsid_foxglove_pins)
file(WRITE "${CMAKE_BINARY_DIR}/foxglove-requirements.txt" "${ndsid_foxglove_pins}\n")
install(FILES "${CMAKE_SOURCE_DIR}/scripts/foxglove_bridge.py" "${CMAKE_SOURCE_DIR}/docs/foxglove/ndsid-layout.json"
        DESTINATION "${CMAKE_INSTALL_DATADIR}/ndsid/foxglove")
install(FILES "${CMAKE_BINARY_DIR}/foxglove-requirements.txt" DESTINATION "${CMAKE_INSTALL_DATADIR}/ndsid/foxglove"
        RENAME requirements.txt)
foreach(doc install.md daemon.md monitoring.md configuration.md can-input.md dbc.md)
  if(EXISTS "${CMAKE_SOURCE_DIR}/docs/${doc}")
    install(FILES "${CMAKE_SOURCE_DIR}/docs/${doc}" DESTINATION "${CMAKE_INSTALL_DOCDIR}")
  endif()
endforeach()
install(FILES "${CMAKE_SOURCE_DIR}/README.md" "${CMAKE_SOURCE_DIR}/CHANGELOG.md" DESTINATION "${CMAKE_INSTALL_DOCDIR}")

include(cmake/package.cmake)
