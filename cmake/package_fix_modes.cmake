# CPACK_PRE_BUILD_SCRIPTS (cmake/package.cmake): runs on CPack's staging tree before the .deb is
# made. Folders the install creates below DESTDIR (usr/, usr/share/, etc/ndsid/, ...) get the
# packager's umask (0700 under umask 077), and dpkg would create them so on the target; make
# every folder 0755. Files keep the modes install() gave them (0644, 0755 for programs).
foreach(var CPACK_TEMPORARY_INSTALL_DIRECTORY CPACK_TEMPORARY_DIRECTORY)
  if(DEFINED ${var} AND IS_DIRECTORY "${${var}}")
    set(stage "${${var}}")
    break()
  endif()
endforeach()
if(NOT stage)
  message(FATAL_ERROR "ndsid: CPack's staging folder is not known; cannot fix folder modes")
endif()
file(GLOB_RECURSE entries LIST_DIRECTORIES true "${stage}/*")
set(dirs "${stage}")
foreach(e IN LISTS entries)
  if(IS_DIRECTORY "${e}" AND NOT IS_SYMLINK "${e}")
    list(APPEND dirs "${e}")
  endif()
endforeach()
file(CHMOD ${dirs} PERMISSIONS OWNER_READ OWNER_WRITE OWNER_EXECUTE GROUP_READ GROUP_EXECUTE WORLD_READ WORLD_EXECUTE)
