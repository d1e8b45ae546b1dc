// Crash-safe file replacement: write a temporary file beside the target, fsync it, rename it
// over the target, fsync the directory. A reader sees the old or the new file, never a mix.
// File modes: a replaced file keeps its mode and owner (a config edited by root stays readable
// by the service); a new file gets 0666 minus the umask, like any file the process creates.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace ndsid {

// Throws ndsid::Error (with the path and errno text) when any step fails, also when the old
// file's owner cannot be kept (no privilege to chown); the target is then untouched and the
// temporary file removed. A symlink is followed: its destination is replaced, the link stays.
void WriteFileAtomically(const std::string& path, std::string_view contents);

inline constexpr size_t kMaxReadBytes = size_t{1} << 30;  // 1 GiB: no input of ours is near it

// Reads a whole file; throws ndsid::Error naming the path when it cannot be opened or read
// (every read error counts, EIO as well as a directory given for a file) or is larger than
// `max_bytes`.
std::string ReadWholeFile(const std::string& path, size_t max_bytes = kMaxReadBytes);

}  // namespace ndsid
