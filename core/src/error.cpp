#include "lfi/core/error.h"

namespace lfi {

const char* toString(Errc code) {
  switch (code) {
    case Errc::InvalidArgument: return "invalid argument";
    case Errc::InvalidFile: return "invalid file";
    case Errc::Checksum: return "checksum mismatch";
    case Errc::Io: return "I/O error";
    case Errc::Exists: return "already exists";
    case Errc::NotFound: return "not found";
    case Errc::Config: return "configuration error";
    case Errc::Device: return "device error";
    case Errc::Timeout: return "timeout";
    case Errc::Cancelled: return "cancelled";
  }
  return "unknown error";
}

}  // namespace lfi
