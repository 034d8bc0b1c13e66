// SPDX-License-Identifier: Apache-2.0
#pragma once
// The one policy for where a command writes (the study, the CLI's commands,
// a run): the folder is made and proved writable, and files that would be
// replaced are refused, before any work, so that a long job never fails at
// its end for want of a folder or silently replaces what a user kept.

#include "lfi/core/atomic_file.h"

#include <filesystem>
#include <string_view>
#include <vector>

namespace lfi {

// Makes `folder` (and its parents) and checks that files can be made in it:
// Errc::Io "<who>: cannot make the folder '<folder>' for <what>: <reason>" (or
// "cannot write into"). An empty path is the working folder (a bare file
// name's parent).
void requireOutputFolder(const std::filesystem::path& folder, std::string_view who, std::string_view what);

// Unless `overwrite` is Allow, Errc::Exists for the first of `files` that
// exists ("'<file>' exists; refusing to overwrite it (use --force to replace
// it)"); Errc::Io naming `who` when that cannot be told.
void refuseExisting(const std::vector<std::filesystem::path>& files, Overwrite overwrite, std::string_view who);

}  // namespace lfi
