// Crash-safe file replacement: write a temporary file beside the target, fsync it, rename it
// over the target, fsync the directory. A reader sees the old or the new file, never a mix.
// File modes: a replaced file keeps its mode and owner (a config edited by root stays readable
// by the service); a new file gets 0666 minus the umask, like any file the process creates.
#pragma once

#include <string>
#include <string_view>

namespace ndsid {

// Throws ndsid::Error (with the path and errno text) when any step fails, also when the old
// file's owner cannot be kept (no privilege to chown); the target is then untouched and the
// temporary file removed. A symlink is followed: its destination is replaced, the link stays.
void WriteFileAtomically(const std::string& path, std::string_view contents);

// Reads a whole file; throws ndsid::Error naming the path when it cannot.
std::string ReadWholeFile(const std::string& path);

}  // namespace ndsid
