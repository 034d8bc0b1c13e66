// SPDX-License-Identifier: Apache-2.0
#pragma once
// The project's one exception type (docs/contributing.md). It is thrown for what stops an
// operation: a bad file, a bad configuration, a device that is not there, a
// protocol violation. Its message always names the file and field, or the device
// and request. What a caller handles in a loop (a frame timeout, an incomplete
// frame) is a value, not an Error.

#include <fmt/format.h>

#include <stdexcept>
#include <string>
#include <string_view>

namespace lfi {

enum class Errc {
  InvalidArgument,  // a caller passed a value outside its documented range
  InvalidFile,      // a file exists but its content is wrong (format, attribute, size)
  Checksum,         // a file's content does not match its recorded checksum
  Io,               // the operating system refused a read or write
  Exists,           // the target exists and overwriting was not asked for
  NotFound,         // a file, device or key that was asked for is not there
  Config,           // a bench, scene or URI has a malformed or unknown field
  Device,           // a device refused, vanished or answered nonsense
  Timeout,          // an operation did not finish in time
  Cancelled,        // the user or caller cancelled a long operation
};

const char* toString(Errc code);

class Error : public std::runtime_error {
 public:
  Error(Errc code, const std::string& message) : std::runtime_error(message), code_(code) {}
  Errc code() const noexcept { return code_; }

 private:
  Errc code_;
};

// Text read from a file, fit for a message: printable ASCII as it is, every
// other byte as \xNN, cut to at most `limit` characters of the original ("...").
std::string shown(std::string_view text, size_t limit = 40);

// Builds and throws an Error with a {fmt}-formatted message.
template <typename... Args>
[[noreturn]] void fail(Errc code, fmt::format_string<Args...> format, Args&&... args) {
  throw Error(code, fmt::format(format, std::forward<Args>(args)...));
}

}  // namespace lfi
