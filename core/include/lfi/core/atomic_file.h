#pragma once
// Atomic, non-clobbering writes for files users care about (captured light
// fields, calibrations, study results). The content is written to a temporary
// file in the target's directory, flushed to disk, and renamed over the target
// in one step; a failure at any point leaves the old file untouched and removes
// the temporary. Without Overwrite::Allow an existing target is never replaced
// (checked atomically by the rename itself, not by a racy stat). A target that
// is a symbolic link is written where the link points; the link stays. A
// SIGINT, SIGTERM or SIGHUP that would end the process while a temporary is
// being written (its default action) removes the temporary first.

#include <filesystem>
#include <functional>
#include <string_view>

namespace lfi {

enum class Overwrite { Refuse, Allow };

// Calls writeTo(temporaryPath) to produce the content, then publishes it at
// `target`. Throws Errc::Exists (Refuse and target exists) or Errc::Io; any
// exception thrown by writeTo propagates after the temporary is removed.
void writeFileAtomically(const std::filesystem::path& target, Overwrite overwrite,
                         const std::function<void(const std::filesystem::path& temporary)>& writeTo);

// Where writeFileAtomically writes for `path`: the path itself, or the file
// its symbolic links end at (which need not exist yet). Errc::Io for a loop.
std::filesystem::path resolvedTarget(const std::filesystem::path& path);

// Convenience for text and small binary files.
void writeFileAtomically(const std::filesystem::path& target, Overwrite overwrite, std::string_view content);

}  // namespace lfi
