// SPDX-License-Identifier: Apache-2.0
#pragma once
// The check every reader of a user's file makes before it opens it, so that a
// missing file, one it may not look at, or something that is not a file (a
// directory, a FIFO a reader would wait on forever, a device) is named as such.

#include <filesystem>
#include <string_view>

namespace lfi {

// Throws Errc::NotFound ("'<path>': no such <what>"), Errc::Io (the system's
// reason, e.g. permission denied on a directory on the way) or
// Errc::InvalidFile (not a regular file). Symbolic links are followed.
void requireInputFile(const std::filesystem::path& path, std::string_view what = "file");

}  // namespace lfi
