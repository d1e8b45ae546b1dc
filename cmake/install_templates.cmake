# Runs at install time (from cmake/install.cmake's install(CODE)), where CMAKE_INSTALL_PREFIX
# is the prefix of this install (`cmake --install --prefix P`, CPack's /usr), and DESTDIR may
# stage it. Writes the systemd unit and the default configuration with this prefix's paths and
# installs them with file(INSTALL), so they are in install_manifest.txt like any other file.
#
# In: NDSID_SOURCE_DIR, NDSID_STAGING_DIR, NDSID_UNIT_DIR (may be empty), and the
# GNUInstallDirs relative dirs NDSID_SBINDIR, NDSID_SYSCONFDIR, NDSID_DATADIR, NDSID_DOCDIR.

# GNUInstallDirs' rule, applied to the install-time prefix: relative dirs go under the prefix,
# except the configuration of /usr and / (/etc) and of /opt/<x> (/etc/opt/<x>).
function(ndsid_full_dir out rel kind)
  set(prefix "${CMAKE_INSTALL_PREFIX}")
  string(REGEX REPLACE "(.)/+$" "\\1" prefix "${prefix}")
  if(IS_ABSOLUTE "${rel}")
    set(full "${rel}")
  elseif(kind STREQUAL "sysconf" AND (prefix STREQUAL "/usr" OR prefix STREQUAL "/"))
    set(full "/${rel}")
  elseif(kind STREQUAL "sysconf" AND prefix MATCHES "^/opt/(.*)")
    set(full "/${rel}/opt/${CMAKE_MATCH_1}")
  elseif(prefix STREQUAL "/")
    set(full "/${rel}")
  else()
    set(full "${prefix}/${rel}")
  endif()
  set(${out} "${full}" PARENT_SCOPE)
endfunction()

ndsid_full_dir(sbin_dir "${NDSID_SBINDIR}" plain)
ndsid_full_dir(etc_dir "${NDSID_SYSCONFDIR}" sysconf)
ndsid_full_dir(data_dir "${NDSID_DATADIR}" plain)
ndsid_full_dir(doc_dir "${NDSID_DOCDIR}" plain)
set(config_dir "${etc_dir}/ndsid")
if(NDSID_UNIT_DIR)
  set(unit_dir "${NDSID_UNIT_DIR}")
else()
  ndsid_full_dir(unit_dir "lib/systemd/system" plain)
endif()
file(MAKE_DIRECTORY "${NDSID_STAGING_DIR}")

# The unit: systemd/ndsidd.service names the /usr paths; only those three are rewritten.
file(READ "${NDSID_SOURCE_DIR}/systemd/ndsidd.service" unit)
string(REPLACE "/usr/sbin/ndsidd" "${sbin_dir}/ndsidd" unit "${unit}")
string(REPLACE "/etc/ndsid/" "${config_dir}/" unit "${unit}")
string(REPLACE "/usr/share/doc/ndsid/" "${doc_dir}/" unit "${unit}")
file(WRITE "${NDSID_STAGING_DIR}/ndsidd.service" "${unit}")
file(INSTALL DESTINATION "${unit_dir}" TYPE FILE PERMISSIONS OWNER_READ OWNER_WRITE GROUP_READ WORLD_READ FILES "${NDSID_STAGING_DIR}/ndsidd.service")

# The default configuration: the example vehicle on the live bus can0, its DBC where it is
# installed, the learned state where the unit's StateDirectory= puts it. Every path in it
# exists after the install (the state folder once systemd has started the service).
file(READ "${NDSID_SOURCE_DIR}/config/example_vehicle.yaml" cfg)
set(header
"# Installed by ndsid as ${config_dir}/vehicle.yaml: the example vehicle of
# ${data_dir}/ndsid/dbc/ndsid_example.dbc on the live bus can0, for ndsidd.service.
# Put your vehicle's DBC, signal roles and data sheet here (${doc_dir}/configuration.md),
# then: ndsidd --config ${config_dir}/vehicle.yaml --check-config
")
string(REGEX REPLACE "^# Example vehicle configuration[^\n]*\n(#[^\n]*\n)*" "${header}" cfg "${cfg}")
set(source_block
"source:
  type: socketcan             # log | socketcan
  interface: can0             # the SocketCAN interface (rename it in ndsidd.service's Wants=/After= too)
  bus: \"\"                     # in a multi-bus log, use only this bus (\"\" = all)
")
string(REGEX REPLACE "\nsource:\n(  [^\n]*\n)+" "\n${source_block}" cfg "${cfg}")
string(REGEX REPLACE "\ndbc: [^\n]*" "\ndbc: ${data_dir}/ndsid/dbc/ndsid_example.dbc" cfg "${cfg}")
string(REGEX REPLACE "\nstate_dir: [^\n]*" "\nstate_dir: /var/lib/ndsid        # ndsidd.service's StateDirectory=ndsid" cfg "${cfg}")
string(REGEX REPLACE "\nreport_dir: [^\n]*"
       "\n# report_dir: DIR            # reports of the ndsid commands (absent: out/report under the working directory)"
       cfg "${cfg}")
foreach(expect "type: socketcan" "interface: can0" "dbc: /" "state_dir: /var/lib/ndsid")
  string(FIND "${cfg}" "${expect}" at)
  if(at LESS 0)
    message(FATAL_ERROR "ndsid: config/example_vehicle.yaml changed shape; the installed config lacks '${expect}'")
  endif()
endforeach()
file(WRITE "${NDSID_STAGING_DIR}/vehicle.yaml" "${cfg}")

# A plain `cmake --install` over an edited configuration keeps it and puts the new default
# beside it (the Debian package leaves this to dpkg: the file is a conffile).
set(existing "$ENV{DESTDIR}${config_dir}/vehicle.yaml")
if(EXISTS "${existing}")
  file(READ "${existing}" old)
endif()
if(EXISTS "${existing}" AND NOT old STREQUAL cfg)
  message(STATUS "Keeping ${existing}; the new default goes in as vehicle.yaml.example")
  file(INSTALL DESTINATION "${config_dir}" TYPE FILE RENAME vehicle.yaml.example
       PERMISSIONS OWNER_READ OWNER_WRITE GROUP_READ WORLD_READ
       FILES "${NDSID_STAGING_DIR}/vehicle.yaml")
else()
  file(INSTALL DESTINATION "${config_dir}" TYPE FILE PERMISSIONS OWNER_READ OWNER_WRITE GROUP_READ WORLD_READ FILES "${NDSID_STAGING_DIR}/vehicle.yaml")
endif()
