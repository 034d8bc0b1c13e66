// SPDX-License-Identifier: Apache-2.0
#pragma once
// Reading a text file whole and editing shipped bench and scene files' text in
// tests and benchmarks: an edit whose text is not there throws (the file
// changed under it), which fails the test; it never passes unedited.

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

namespace lfi::testing_support {

inline std::string readText(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

inline void replaceOnce(std::string& text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  if (at == std::string::npos) throw std::runtime_error("the text to replace is not there: " + from);
  text.replace(at, from.size(), to);
}

inline void replaceAll(std::string& text, const std::string& from, const std::string& to) {
  if (text.find(from) == std::string::npos) throw std::runtime_error("the text to replace is not there: " + from);
  for (size_t at = 0; (at = text.find(from, at)) != std::string::npos; at += to.size())
    text.replace(at, from.size(), to);
}

}  // namespace lfi::testing_support
