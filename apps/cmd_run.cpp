// SPDX-License-Identifier: Apache-2.0
// lfi run BENCH: parts inspected one after another, one per image, until
// stopped (SIGINT or SIGTERM, a part count, or a time): one JSON Lines record
// per part, each flushed to the disk before the next part; a summary page
// rebuilt from the records; progress on the terminal. A device that fails
// mid-run is recorded against the part in hand; the run then stops, or, with
// [run] on_device_loss = "wait", reopens the devices with a bounded back-off.

#include "bench_cli.h"
#include "cli_util.h"
#include "commands.h"
#include "part_output.h"
#include "run_summary.h"

#include "lfi/controller/bench_devices.h"
#include "lfi/controller/inspector.h"
#include "lfi/controller/reference_package.h"
#include "lfi/core/error.h"
#include "lfi/core/log.h"
#include "lfi/core/output_folder.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <memory>
#include <thread>

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace lfi::cli {

namespace {

struct RunArgs {
  fs::path bench, part, out;
  long parts = 0;      // 0: no limit
  double seconds = 0;  // 0: no limit
};

// The records file, appended to one whole line at a time and flushed to the
// disk after each (a crash loses at most the line being written).
class RecordLog {
 public:
  explicit RecordLog(fs::path file) : file_(std::move(file)) {
    fd_ = ::open(file_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_APPEND | O_CLOEXEC, 0666);
    if (fd_ < 0) fail(Errc::Io, "run: cannot create '{}': {}", file_.string(), std::strerror(errno));
  }
  ~RecordLog() { ::close(fd_); }
  RecordLog(const RecordLog&) = delete;
  RecordLog& operator=(const RecordLog&) = delete;
  void append(const InspectionRecord& record) {
    const std::string line = recordText(record, -1) + "\n";
    size_t done = 0;
    while (done < line.size()) {
      const ssize_t n = ::write(fd_, line.data() + done, line.size() - done);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0)
        fail(Errc::Io, "run: cannot append part {}'s record to '{}': {} (the records before it are kept)", record.part,
             file_.string(), n < 0 ? std::strerror(errno) : "nothing written");
      done += static_cast<size_t>(n);
    }
    if (::fdatasync(fd_) != 0 && errno != EINVAL)
      fail(Errc::Io, "run: cannot flush '{}': {} (the records before part {} are kept)", file_.string(),
           std::strerror(errno), record.part);
  }
  const fs::path& file() const { return file_; }

 private:
  fs::path file_;
  int fd_ = -1;
};

// The devices and the inspector over them, opened (again) as one.
struct Station {
  std::unique_ptr<Display> display;
  std::unique_ptr<Camera> camera;
  std::unique_ptr<Inspector> inspector;
};

Station openStation(const BenchFile& bench, const ReferencePackage& package) {
  Station s;
  s.display = openBenchDisplay(bench);
  s.camera = openBenchCamera(bench);
  s.inspector = std::make_unique<Inspector>(bench, package, *s.display, *s.camera);
  s.inspector->showReference();
  return s;
}

// A device error: what on_device_loss = "wait" rides out.
bool deviceTrouble(const Error& e) {
  return e.code() == Errc::Device || e.code() == Errc::Timeout || e.code() == Errc::NotFound;
}

// Reopens the devices with a doubling back-off (0.5 s to 8 s) until the bench's wait limit.
Station reopenStation(const BenchFile& bench, const ReferencePackage& package, const std::string& why) {
  const auto deadline = Clock::now() + std::chrono::duration<double>(bench.waitLimit_s);
  auto pause = std::chrono::milliseconds(500);
  std::string last = why;
  while (!StopOnSignal::stopRequested()) {
    spdlog::warn("run: waiting for the devices ({}); retrying in {} ms", last, pause.count());
    if (Clock::now() + pause > deadline) break;
    std::this_thread::sleep_for(pause);
    try {
      return openStation(bench, package);
    } catch (const Error& e) {
      if (!deviceTrouble(e)) throw;
      last = e.what();
    }
    pause = std::min(pause * 2, std::chrono::milliseconds(8000));
  }
  if (StopOnSignal::stopRequested()) fail(Errc::Cancelled, "run: stopped while waiting for the devices ({})", last);
  fail(Errc::Device, "run: the devices did not come back within {} s ([run] wait_limit_s): {}", bench.waitLimit_s,
       last);
}

int runRun(const RunArgs& a, const GlobalOptions& global) {
  const StopOnSignal stop;  // (from the start: a Ctrl-C while the devices open ends the run before its first part)
  const BenchFile bench = readBenchFile(a.bench);
  // The devices: the bench's, or those of --part's scene on a simulated bench (a bench that cannot take
  // --part is the first thing to say).
  const BenchFile devices = a.part.empty() ? bench : withSimulatedPart(bench, a.part);
  const ReferencePackage package = readReferencePackage(bench.referenceFolder, &bench);
  const fs::path folder = a.out.empty() ? bench.outputFolder / timedFolderName("run", utcNow()) : a.out;
  Station station = openStation(devices, package);
  requireOutputFolder(folder / "images", "run", a.out.empty() ? "[output] folder" : "--out");
  RecordLog log(folder / "records.jsonl");
  const fs::path page = folder / "summary.html";
  fmt::print(stderr, "run: records in {} (Ctrl-C stops after the part in hand)\n", log.file().string());
  const auto start = Clock::now();
  auto lastPage = start;
  Clock::duration pageTime{};
  RunCounts counts;
  std::uint64_t part = 0;
  const auto done = [&] {
    return StopOnSignal::stopRequested() || (a.parts > 0 && static_cast<long>(part) >= a.parts) ||
           (a.seconds > 0 && Clock::now() - start >= std::chrono::duration<double>(a.seconds));
  };
  while (!done()) {
    ++part;
    try {
      const PartInspection result = station.inspector->inspectPart();
      const std::string time = utcNow();
      log.append(partRecord(bench, *station.inspector, result, part, time, folder / "images",
                            fmt::format("part-{:06d}", part)));
      (result.verdict.pass ? counts.passed : counts.failed) += 1;
    } catch (const Error& e) {
      if (!deviceTrouble(e)) {
        // Not the devices (a full disk, a file that cannot be written): record what can be, and stop.
        try {
          log.append(errorRecord(bench, part, utcNow(), e.what()));
          writeRunSummary(log.file(), page, false);
        } catch (const Error&) {
          // (the disk may take nothing more: the records before this part are on it)
        }
        fail(e.code(), "run: stopped at part {}: {} (the records before it are in {})", part, e.what(),
             log.file().string());
      }
      if (e.code() == Errc::Timeout && bench.camera.trigger == TriggerMode::Line) {
        --part;  // a hardware-triggered camera that saw no trigger: no part came, none is missing
        continue;
      }
      log.append(errorRecord(bench, part, utcNow(), e.what()));
      ++counts.errors;
      if (bench.onDeviceLoss == OnDeviceLoss::Stop) {
        writeRunSummary(log.file(), page, false);
        fail(e.code(), "run: part {} could not be inspected: {} (its record and all before it are in {})", part,
             e.what(), log.file().string());
      }
      station.inspector.reset();  // (the devices closed, in the order they depend on each other, before reopening)
      station.camera.reset();
      station.display.reset();
      try {
        station = reopenStation(devices, package, e.what());
      } catch (const Error&) {
        writeRunSummary(log.file(), page, false);
        throw;
      }
    }
    ++counts.parts;
    const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
    if (!global.quiet)
      fmt::print(stderr, "\rpart {}: {} passed, {} failed, {} not inspected, {:.2f} parts/s   ", part, counts.passed,
                 counts.failed, counts.errors, part / std::max(elapsed, 1e-9));
    // The page is rebuilt from all the records: every 2 s, or less often once that takes long (a long run's file).
    if (Clock::now() - lastPage > std::max<Clock::duration>(std::chrono::seconds(2), 20 * pageTime)) {
      const auto begin = Clock::now();
      writeRunSummary(log.file(), page, true);
      lastPage = Clock::now();
      pageTime = lastPage - begin;
    }
  }
  if (!global.quiet) fmt::print(stderr, "\n");
  counts = writeRunSummary(log.file(), page, false);
  const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
  fmt::print("{} parts in {:.1f} s ({:.2f} parts/s): {} passed, {} failed, {} not inspected\n{}\n{}\n", counts.parts,
             elapsed, counts.parts / std::max(elapsed, 1e-9), counts.passed, counts.failed, counts.errors,
             log.file().string(), page.string());
  return 0;
}

}  // namespace

Command addRunCommand(CLI::App& app) {
  auto* command =
      app.add_subcommand("run", "Inspect parts one after another until stopped, with records and a summary");
  auto a = std::make_shared<RunArgs>();
  addBenchArgument(*command, a->bench);
  command->add_option("--parts", a->parts, "Stop after this many parts (default: no limit)")
      ->transform(wholeNumberIn(1LL, 1LL << 40));
  command->add_option("--seconds", a->seconds, "Stop after this long (default: no limit)")->check(CLI::PositiveNumber);
  command->add_option("--part", a->part, "Simulated bench: every part is the one of this scene file")
      ->check(CLI::ExistingFile);
  command->add_option("--out", a->out, "Folder for the run (default: a new one in [output] folder)");
  return {command, [a](const GlobalOptions& global) { return runRun(*a, global); }};
}

}  // namespace lfi::cli
