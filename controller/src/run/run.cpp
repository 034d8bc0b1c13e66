// SPDX-License-Identifier: Apache-2.0
#include "lfi/controller/run.h"

#include "lfi/controller/bench_devices.h"
#include "lfi/controller/inspector.h"
#include "lfi/controller/mqtt_output.h"
#include "lfi/controller/part_records.h"
#include "lfi/controller/reject_line.h"
#include "lfi/core/error.h"
#include "lfi/core/log.h"
#include "lfi/core/output_folder.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <memory>
#include <thread>

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace lfi {

RecordLog::RecordLog(fs::path file) : file_(std::move(file)) {
  fd_ = ::open(file_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_APPEND | O_CLOEXEC, 0666);
  if (fd_ < 0) fail(Errc::Io, "run: cannot create '{}': {}", file_.string(), std::strerror(errno));
}

RecordLog::~RecordLog() {
  ::close(fd_);
}

void RecordLog::append(const InspectionRecord& record) {
  const std::string line = recordText(record, -1) + "\n";
  std::size_t done = 0;
  while (done < line.size()) {
    const ssize_t n = ::write(fd_, line.data() + done, line.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0)
      fail(Errc::Io, "run: cannot append part {}'s record to '{}': {} (the records before it are kept)", record.part,
           file_.string(), n < 0 ? std::strerror(errno) : "nothing written");
    done += static_cast<std::size_t>(n);
  }
  if (::fdatasync(fd_) != 0 && errno != EINVAL)
    fail(Errc::Io, "run: cannot flush '{}': {} (the records before part {} are kept)", file_.string(),
         std::strerror(errno), record.part);
}

namespace {

// The devices and the inspector over them, opened (again) as one; closed in
// the order they depend on each other.
struct Station {
  std::unique_ptr<Display> display;
  std::unique_ptr<Camera> camera;
  std::unique_ptr<Inspector> inspector;
  std::unique_ptr<RejectLine> line;  // [output.line]

  void close() {
    line.reset();
    inspector.reset();
    camera.reset();
    display.reset();
  }
};

Station openStation(const BenchFile& bench, const ReferencePackage& package,
                    const std::shared_ptr<const PartModel>& part, const std::optional<LineOutputSettings>& line) {
  Station s;
  s.display = openBenchDisplay(bench);
  s.camera = openBenchCamera(bench);
  s.inspector = std::make_unique<Inspector>(bench, package, *s.display, *s.camera, part);
  s.inspector->showReference();
  if (line) s.line = std::make_unique<RejectLine>(*s.camera, *line);
  return s;
}

// A device error: what on_device_loss = "wait" rides out.
bool deviceTrouble(const Error& e) {
  return e.code() == Errc::Device || e.code() == Errc::Timeout || e.code() == Errc::NotFound;
}

class Run {
 public:
  Run(const BenchFile& bench, const BenchFile& devices, const ReferencePackage& package, const RunOptions& options)
      : bench_(bench), devices_(devices), package_(package), options_(options) {}

  RunResult operator()() {
    // (the output's files are checked before the devices open; a run that fails to start leaves its will)
    if (bench_.mqtt) mqtt_ = std::make_unique<MqttOutput>(*bench_.mqtt);
    Station station = open();
    requireOutputFolder(options_.folder / "images", "run", "its records and images");
    RecordLog log(options_.folder / "records.jsonl");
    log_ = &log;
    if (mqtt_) mqtt_->publishState(RunState::Running);
    page_ = options_.folder / "summary.html";
    start_ = lastPage_ = Clock::now();
    while (!done()) {
      ++part_;
      try {
        inspect(station);
      } catch (const Error& e) {
        if (!onError(e)) continue;  // no part came
        station.close();
        station = reopen(e.what());
      }
      ++counts_.parts;
      if (options_.onPart) options_.onPart(counts_, seconds());
      refreshPage();
    }
    RunResult result{writeRunSummary(log.file(), page_, false), seconds(), log.file(), page_, {}};
    if (mqtt_) result.outputProblems = mqtt_->finish();
    return result;
  }

 private:
  bool stopRequested() const { return options_.stopRequested && options_.stopRequested(); }
  double seconds() const { return std::chrono::duration<double>(Clock::now() - start_).count(); }
  bool done() const {
    return stopRequested() || (options_.parts > 0 && static_cast<long>(part_) >= options_.parts) ||
           (options_.seconds > 0 && seconds() >= options_.seconds);
  }

  Station open() const { return openStation(devices_, package_, options_.partModel, bench_.line); }

  // The part's record to the log, then to the broker and the caller.
  void record(const InspectionRecord& r) {
    log_->append(r);
    if (mqtt_) mqtt_->publishRecord(r.part, recordText(r, -1));
    if (options_.onRecord) options_.onRecord(r);
  }

  // A failed part raises the output line at its verdict; the line is low again before the next part.
  void inspect(Station& station) {
    const PartInspection result = station.inspector->inspectPart();
    if (station.line && !result.verdict.pass) station.line->raise();
    record(partRecord(bench_, *station.inspector, result, part_, utcNow(), options_.folder / "images",
                      fmt::format("part-{:06d}", part_)));
    (result.verdict.pass ? counts_.passed : counts_.failed) += 1;
    if (station.line) station.line->lower();
  }

  // Records a part that failed; throws when the run stops, and returns false
  // when no part came (a line-triggered camera without a trigger).
  bool onError(const Error& e) {
    if (!deviceTrouble(e)) {
      // Not the devices (a full disk, a file that cannot be written): record what can be, and stop.
      try {
        record(errorRecord(bench_, part_, utcNow(), e.what()));
        writeRunSummary(log_->file(), page_, false);
      } catch (const Error&) {
        // (the disk may take nothing more: the records before this part are on it)
      }
      fail(e.code(), "run: stopped at part {}: {} (the records before it are in {})", part_, e.what(),
           log_->file().string());
    }
    if (e.code() == Errc::Timeout && bench_.camera.trigger == TriggerMode::Line) {
      --part_;
      return false;
    }
    record(errorRecord(bench_, part_, utcNow(), e.what()));
    ++counts_.errors;
    if (bench_.onDeviceLoss == OnDeviceLoss::Stop) {
      writeRunSummary(log_->file(), page_, false);
      fail(e.code(), "run: part {} could not be inspected: {} (its record and all before it are in {})", part_,
           e.what(), log_->file().string());
    }
    return true;
  }

  // Reopens the devices with a doubling back-off (0.5 s to 8 s) whose pauses
  // add up to at most the bench's wait limit.
  Station reopen(const std::string& why) {
    try {
      auto pause = std::chrono::milliseconds(500);
      std::chrono::duration<double> waited{};
      const std::chrono::duration<double> limit(bench_.waitLimit_s);
      std::string last = why;
      if (mqtt_) mqtt_->publishState(RunState::Waiting);
      while (!stopRequested()) {
        if (waited + pause > limit)
          fail(Errc::Device, "run: the devices did not come back within {} s ([run] wait_limit_s): {}",
               bench_.waitLimit_s, last);
        spdlog::warn("run: waiting for the devices ({}); retrying in {} ms", last, pause.count());
        if (options_.pause)
          options_.pause(pause);
        else
          std::this_thread::sleep_for(pause);
        waited += pause;
        try {
          Station station = open();
          if (mqtt_) mqtt_->publishState(RunState::Running);
          return station;
        } catch (const Error& e) {
          if (!deviceTrouble(e)) throw;
          last = e.what();
        }
        pause = std::min(pause * 2, std::chrono::milliseconds(8000));
      }
      fail(Errc::Cancelled, "run: stopped while waiting for the devices ({})", last);
    } catch (const Error&) {
      writeRunSummary(log_->file(), page_, false);
      throw;
    }
  }

  // The page is rebuilt from all the records: every 2 s, or less often once that takes long (a long run's file).
  void refreshPage() {
    if (Clock::now() - lastPage_ <= std::max<Clock::duration>(std::chrono::seconds(2), 20 * pageTime_)) return;
    const auto begin = Clock::now();
    writeRunSummary(log_->file(), page_, true);
    lastPage_ = Clock::now();
    pageTime_ = lastPage_ - begin;
  }

  const BenchFile& bench_;
  const BenchFile& devices_;
  const ReferencePackage& package_;
  const RunOptions& options_;
  RecordLog* log_ = nullptr;
  std::unique_ptr<MqttOutput> mqtt_;  // [output.mqtt]
  fs::path page_;
  Clock::time_point start_, lastPage_;
  Clock::duration pageTime_{};
  RunCounts counts_;
  std::uint64_t part_ = 0;
};

}  // namespace

RunResult runParts(const BenchFile& bench, const BenchFile& devices, const ReferencePackage& package,
                   const RunOptions& options) {
  return Run(bench, devices, package, options)();
}

}  // namespace lfi
