// SPDX-License-Identifier: Apache-2.0
#pragma once
// Changing values of a bench file the way a person would: each value
// replaced where it stands, new keys after their table's last key, new tables
// after their parent's keys, and every other byte (comments, order, blank
// lines) left as it was. The calibrations write their results this way.
//
// Publishing a calibration (publishCalibration): beside the bench file
// `<dir>/<name>.toml` the folder `<dir>/<name>.calibrations/` keeps, for
// each calibration, the bench file as it was before (`<stamp>-<what>.before.toml`)
// and the calibration's record (`<stamp>-<what>.json`: date, method, values,
// uncertainties, residuals), neither ever overwritten; then the bench file is
// replaced in one step (core/atomic_file.h) by the edited text, once that text
// has been read back as a bench file. A bench file that changed on disk since
// it was read is not replaced.

#include <filesystem>
#include <optional>
#include <string>

namespace lfi {

class BenchFileEdit {
 public:
  // Reads the file. Errc::NotFound; Errc::Config when it is not TOML.
  explicit BenchFileEdit(std::filesystem::path file);

  // Sets `key` of `table` (dotted: "camera", "display.optics"; "": the file's own keys) to `value`,
  // TOML text (a number, a quoted string, an array), with "  # comment" after
  // it when `comment` is not empty (replacing the comment the line had).
  // Errc::InvalidArgument for a key or table name that is not a bare TOML key,
  // or for a key that holds a table.
  void set(const std::string& table, const std::string& key, const std::string& value, const std::string& comment = {});

  // Removes the line of `key` in `table` (nothing when it is absent).
  // Errc::InvalidArgument when the key holds a table or shares its line.
  void remove(const std::string& table, const std::string& key);

  // The string `key` of `table` holds in the text as it is now; empty when the key is absent or not a string.
  std::optional<std::string> string(const std::string& table, const std::string& key) const;

  const std::filesystem::path& file() const { return file_; }
  const std::string& original() const { return original_; }
  const std::string& text() const { return text_; }
  // The lines that change, for a dry run: "- <line> | old" with its line in
  // the file as it is, "+ <line> | new" with its line in the file edited.
  std::string changes() const;

 private:
  std::filesystem::path file_;
  std::string original_, text_;
};

// `text` as a TOML basic string, quotes and escapes included.
std::string tomlString(const std::string& text);

struct PublishedCalibration {
  std::filesystem::path backup;  // the bench file as it was
  std::filesystem::path record;
};

// `<dir>/<name>.calibrations/<stamp>-<what><extension>` for the bench file
// `<dir>/<name>.toml`: where a calibration keeps its files.
std::filesystem::path calibrationFile(const std::filesystem::path& benchFile, const std::string& stampUtc,
                                      const std::string& what, const std::string& extension);

// Publishes `edit` as above: `what` names the calibration ("display"),
// `stampUtc` its time (ISO 8601; colons are left out of the names),
// `recordJson` the record's text. Errc::Exists when the bench file is no
// longer what `edit` read, or a record of that name exists; Errc::Config
// (naming the bench file) when the edited text does not read as a bench file;
// Errc::Io. Nothing is replaced on any error.
PublishedCalibration publishCalibration(const BenchFileEdit& edit, const std::string& what, const std::string& stampUtc,
                                        const std::string& recordJson);

}  // namespace lfi
