// SPDX-License-Identifier: Apache-2.0
#pragma once
// A run (`lfi run`, docs/inspection.md "Runs"): parts inspected one after
// another until stopped (a stop request, a part count or a time), one JSON
// Lines record per part flushed to the disk before the next part
// (RecordLog), a summary page rebuilt from the records (run_summary.h), and
// the run's images. A device that fails mid-run is recorded against the part
// in hand; the run then stops, or, with [run] on_device_loss = "wait",
// reopens the devices with a doubling back-off (0.5 s to 8 s) whose pauses
// add up to at most [run] wait_limit_s. A hardware-triggered camera that saw
// no trigger in time means no part came: nothing is recorded. The bench's
// [output.mqtt] publishes each record and the run's state as they happen
// (mqtt_output.h); its [output.line] pulses the camera's output line on each
// failed part (reject_line.h).

#include "lfi/controller/bench_file.h"
#include "lfi/controller/inspection_record.h"
#include "lfi/controller/reference_package.h"
#include "lfi/controller/run_summary.h"

#include "lfi/core/part_model.h"

#include <chrono>
#include <cstdint>

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace lfi {

// The records file of a run, created new (Errc::Io naming it when it exists
// or cannot be made), appended one whole line at a time and flushed to the
// disk after each (a crash loses at most the line being written).
class RecordLog {
 public:
  explicit RecordLog(std::filesystem::path file);
  ~RecordLog();
  RecordLog(const RecordLog&) = delete;
  RecordLog& operator=(const RecordLog&) = delete;
  // Throws Errc::Io naming the file and the part when the line cannot be
  // written or flushed (the records before it are kept).
  void append(const InspectionRecord& record);
  const std::filesystem::path& file() const { return file_; }

 private:
  std::filesystem::path file_;
  int fd_ = -1;
};

struct RunOptions {
  std::filesystem::path folder;  // the run's: records.jsonl, summary.html, images/ (made if missing)
  long parts = 0;                // stop after this many parts; 0: no limit
  double seconds = 0;            // stop after this long; 0: no limit
  // Asked between parts and while waiting for the devices; true ends the run
  // after the part in hand (a wait ends with Errc::Cancelled).
  std::function<bool()> stopRequested;
  // After each part: the counts so far and the seconds since the start.
  std::function<void(const RunCounts& counts, double seconds)> onPart;
  // Each part's record, once it is in the log.
  std::function<void(const InspectionRecord& record)> onRecord;
  // The back-off's pause before reopening the devices (this thread sleeps by default).
  std::function<void(std::chrono::milliseconds pause)> pause;
  // The part's model (the bench's [geometry] part_model, loaded by the caller): defects placed inside the part too.
  std::shared_ptr<const PartModel> partModel;
};

struct RunResult {
  RunCounts counts;  // as the records say (the summary's)
  double seconds = 0;
  std::filesystem::path records, page;
  // What went wrong with the outputs ([output.mqtt]: an unreachable broker, a refused connection, records
  // not published or not acknowledged), each naming the broker; the records are in `records` all the same.
  std::vector<std::string> outputProblems;
};

// Runs parts on `devices` (the bench's, or a simulated bench's with another
// part: withSimulatedPart in the CLI) against the reference `package` of
// `bench`. Throws Errc::Io when the folder cannot take files (before any
// part), the device errors of a part with on_device_loss = "stop" or of a
// wait past its limit (Errc::Device), Errc::Cancelled for a stop while
// waiting, and any other error of a part; in every case after recording the
// part and rewriting the summary page where the disk lets it.
RunResult runParts(const BenchFile& bench, const BenchFile& devices, const ReferencePackage& package,
                   const RunOptions& options);

}  // namespace lfi
