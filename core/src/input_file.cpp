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
  if (status.type() != std::filesystem::file_type::regular)
    fail(Errc::InvalidFile, "'{}': not a regular file (a directory, FIFO, socket or device)", path.string());
}

}  // namespace lfi
