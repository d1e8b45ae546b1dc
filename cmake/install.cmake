# Install rules for the service (included by the top-level CMakeLists.txt). With
# -DCMAKE_INSTALL_PREFIX=/usr this gives:
#   /usr/sbin/ndsidd, /usr/bin/ndsid                     (src/service, src/desk CMakeLists.txt)
#   /usr/lib/systemd/system/ndsidd.service               (paths rewritten to the prefix)
#   /etc/ndsid/vehicle.yaml                              (config/example_vehicle.yaml, state_dir -> /var/lib/ndsid)
#   /usr/share/ndsid/dbc/ndsid_example.dbc               (referenced by the installed config)
#   /usr/share/ndsid/systemd/80-can0.network, 80-vcan0.* (examples for /etc/systemd/network)
#   /usr/share/ndsid/java/ndsid_lcmtypes.jar, lcmtypes/  (lcmtypes/CMakeLists.txt)
#   /usr/share/doc/ndsid/daemon.md, monitoring.md
set(NDSID_UNIT_DIR "${CMAKE_INSTALL_PREFIX}/lib/systemd/system" CACHE PATH "Where ndsidd.service is installed")
set(NDSID_CONFIG_DIR "${CMAKE_INSTALL_FULL_SYSCONFDIR}/ndsid")
set(NDSID_DATA_DIR "${CMAKE_INSTALL_FULL_DATADIR}/ndsid")

# The unit with this prefix's paths.
file(READ "${CMAKE_SOURCE_DIR}/systemd/ndsidd.service" ndsid_unit)
string(REPLACE "/usr/sbin/ndsidd" "${CMAKE_INSTALL_FULL_SBINDIR}/ndsidd" ndsid_unit "${ndsid_unit}")
string(REPLACE "/etc/ndsid/" "${NDSID_CONFIG_DIR}/" ndsid_unit "${ndsid_unit}")
string(REPLACE "/usr/share/doc/ndsid/" "${CMAKE_INSTALL_FULL_DOCDIR}/" ndsid_unit "${ndsid_unit}")
file(WRITE "${CMAKE_BINARY_DIR}/systemd/ndsidd.service" "${ndsid_unit}")
install(FILES "${CMAKE_BINARY_DIR}/systemd/ndsidd.service" DESTINATION "${NDSID_UNIT_DIR}")

# The default configuration: the example vehicle with installed paths (never overwrites an
# edited /etc/ndsid/vehicle.yaml: it goes in as vehicle.yaml.example when one exists).
file(READ "${CMAKE_SOURCE_DIR}/config/example_vehicle.yaml" ndsid_config)
string(REGEX REPLACE "\ndbc: [^\n]*" "\ndbc: ${NDSID_DATA_DIR}/dbc/ndsid_example.dbc" ndsid_config "${ndsid_config}")
string(REGEX REPLACE "\nstate_dir: [^\n]*" "\nstate_dir: /var/lib/ndsid        # systemd StateDirectory=ndsid" ndsid_config "${ndsid_config}")
file(WRITE "${CMAKE_BINARY_DIR}/config/vehicle.yaml" "${ndsid_config}")
install(CODE "
  set(dest \"\$ENV{DESTDIR}${NDSID_CONFIG_DIR}\")
  file(MAKE_DIRECTORY \"\${dest}\")
  if(EXISTS \"\${dest}/vehicle.yaml\")
    message(STATUS \"Keeping \${dest}/vehicle.yaml; new default as vehicle.yaml.example\")
    file(COPY_FILE \"${CMAKE_BINARY_DIR}/config/vehicle.yaml\" \"\${dest}/vehicle.yaml.example\")
  else()
    message(STATUS \"Installing: \${dest}/vehicle.yaml\")
    file(COPY_FILE \"${CMAKE_BINARY_DIR}/config/vehicle.yaml\" \"\${dest}/vehicle.yaml\")
  endif()
")

install(FILES "${CMAKE_SOURCE_DIR}/dbc/ndsid_example.dbc" DESTINATION "${CMAKE_INSTALL_DATADIR}/ndsid/dbc")
install(FILES "${CMAKE_SOURCE_DIR}/systemd/80-can0.network" "${CMAKE_SOURCE_DIR}/systemd/80-vcan0.netdev"
              "${CMAKE_SOURCE_DIR}/systemd/80-vcan0.network"
        DESTINATION "${CMAKE_INSTALL_DATADIR}/ndsid/systemd")
install(PROGRAMS "${CMAKE_SOURCE_DIR}/replay/vcan_replay.sh" DESTINATION "${CMAKE_INSTALL_DATADIR}/ndsid/replay" OPTIONAL)
foreach(doc daemon.md monitoring.md)
  if(EXISTS "${CMAKE_SOURCE_DIR}/docs/${doc}")
    install(FILES "${CMAKE_SOURCE_DIR}/docs/${doc}" DESTINATION "${CMAKE_INSTALL_DOCDIR}")
  endif()
endforeach()
