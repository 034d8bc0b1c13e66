// SPDX-License-Identifier: Apache-2.0
#include "lfi/core/input_file.h"

#include "lfi/core/error.h"

#include <system_error>

namespace lfi {

void requireInputFile(const std::filesystem::path& path, std::string_view what) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (status.type() == std::filesystem::file_type::not_found)
    fail(Errc::NotFound, "'{}': no such {}", path.string(), what);
  if (ec) fail(Errc::Io, "'{}': cannot look at it: {}", path.string(), ec.message());
  using std::filesystem::file_type;
  const file_type type = status.type();
  if (type != file_type::regular)
    fail(Errc::InvalidFile, "'{}': a {}, not a {}", path.string(),
         type == file_type::directory ? "directory"
         : type == file_type::fifo    ? "FIFO (a reader would wait on it)"
         : type == file_type::socket  ? "socket"
                                      : "device or special file",
         what);
}

}  // namespace lfi
