// SPDX-License-Identifier: Apache-2.0
#include "lfi/core/error.h"

namespace lfi {

const char* toString(Errc code) {
  switch (code) {
    case Errc::InvalidArgument:
      return "invalid argument";
    case Errc::InvalidFile:
      return "invalid file";
    case Errc::Checksum:
      return "checksum mismatch";
    case Errc::Io:
      return "I/O error";
    case Errc::Exists:
      return "already exists";
    case Errc::NotFound:
      return "not found";
    case Errc::Config:
      return "configuration error";
    case Errc::Device:
      return "device error";
    case Errc::Timeout:
      return "timeout";
    case Errc::Cancelled:
      return "cancelled";
  }
  return "unknown error";
}

std::string shown(std::string_view text, size_t limit) {
  std::string out;
  for (size_t i = 0; i < text.size() && i < limit; ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c >= 0x20 && c < 0x7f)
      out += static_cast<char>(c);
    else
      out += fmt::format("\\x{:02x}", c);
  }
  if (text.size() > limit) out += "...";
  return out;
}

}  // namespace lfi
