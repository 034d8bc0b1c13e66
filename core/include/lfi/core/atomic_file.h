// SPDX-License-Identifier: Apache-2.0
#pragma once
// Atomic, non-clobbering writes for files users care about (captured light
// fields, calibrations, study results). The content is written to a temporary
// file in the target's directory, flushed to disk, and renamed over the target
// in one step; a failure at any point leaves the old file untouched and removes
// the temporary. Without Overwrite::Allow an existing target is never replaced
// (checked atomically by the rename itself, not by a racy stat). A target that
// is a symbolic link is written where the link points; the link stays. A
// SIGINT, SIGTERM or SIGHUP that would end the process while a temporary is
// being written (its default action) removes the temporary first. A writer
// holds a lock on its temporary while it writes; what a writer that could not
// clean up (SIGKILL, a power cut) left is removed by the next write of the same
// target, once its lock shows the writer is gone.

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

// The same for a folder of files published together (a reference package):
// writeTo(temporaryFolder) fills a new folder next to `target`, every file in
// it is flushed to the disk, and the folder is renamed to `target` in one
// step, or, with Overwrite::Allow, exchanged with an existing `target` in one
// step (the old folder is then removed). Readers see the old folder or the new
// one, never a mix. Throws Errc::Exists (Refuse and target exists) or
// Errc::Io; on any failure the temporary folder is removed and `target` is
// untouched. (A signal that ends the process mid-write leaves the hidden
// temporary folder ".<name>.tmp-XXXXXX" behind, until the next write of
// `target` removes it.)
void writeFolderAtomically(const std::filesystem::path& target, Overwrite overwrite,
                           const std::function<void(const std::filesystem::path& temporaryFolder)>& writeTo);

// Convenience for text and small binary files.
void writeFileAtomically(const std::filesystem::path& target, Overwrite overwrite, std::string_view content);

}  // namespace lfi
