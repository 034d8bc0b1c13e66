// SPDX-License-Identifier: Apache-2.0
#include "lfi/core/output_folder.h"

#include "lfi/core/error.h"

#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <string>

namespace fs = std::filesystem;

namespace lfi {

void requireOutputFolder(const fs::path& given, std::string_view who, std::string_view what) {
  const fs::path folder = given.empty() ? fs::path(".") : given;
  std::error_code made;
  fs::create_directories(folder, made);
  if (made || !fs::is_directory(folder, made))
    fail(Errc::Io, "{}: cannot make the folder '{}' for {}: {}", who, folder.string(), what,
         made ? made.message() : std::string("a file of that name is in the way"));
  if (::access(folder.c_str(), W_OK | X_OK) != 0)  // (files are made in it: it must be searchable too)
    fail(Errc::Io, "{}: cannot write into '{}' for {}: {}", who, folder.string(), what, std::strerror(errno));
}

void refuseExisting(const std::vector<fs::path>& files, Overwrite overwrite, std::string_view who) {
  if (overwrite == Overwrite::Allow) return;
  for (const fs::path& file : files) {
    std::error_code ec;
    if (fs::exists(file, ec))
      fail(Errc::Exists, "'{}' exists; refusing to overwrite it (use --force to replace it)", file.string());
    if (ec) fail(Errc::Io, "{}: cannot look for '{}': {}", who, file.string(), ec.message());
  }
}

}  // namespace lfi
