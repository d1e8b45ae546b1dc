// Crash-safe file replacement: write a temporary file beside the target, fsync it, rename it
// over the target, fsync the directory. A reader sees the old or the new file, never a mix.
#pragma once

#include <string>
#include <string_view>

namespace ndsid {

// Throws ndsid::Error (with the path and errno text) when any step fails; the target is then
// untouched and the temporary file removed.
void WriteFileAtomically(const std::string& path, std::string_view contents);

// Reads a whole file; throws ndsid::Error naming the path when it cannot.
std::string ReadWholeFile(const std::string& path);

}  // namespace ndsid
