// lfi: the command line front end. Every subcommand reports progress on long
// work to stderr, prints results to stdout, and exits non-zero with one clear
// message on error.

#include "lfi/calib/display_distance.h"
#include "lfi/core/atomic_file.h"
#include "lfi/core/error.h"
#include "lfi/drivers/capture_registry.h"
#include "lfi/core/exr_io.h"
#include "lfi/core/log.h"
#include "lfi/core/image.h"
#include "lfi/controller/controller.h"
#include "lfi/drivers/aravis/aravis_camera.h"
#include "lfi/drivers/display_registry.h"
#include "lfi/drivers/aravis/gv_camera_server.h"
#include "lfi/drivers/camera_registry.h"
#include "lfi/drivers/usb/usb_display.h"
#include "lfi/sim/devices/sim_camera.h"
#include "lfi/sim/scene_file.h"
#include "lfi/study/study.h"

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <unistd.h>


#include <atomic>
#include <charconv>
#include <chrono>
#include <cmath>
#include <csignal>
#include <functional>
#include <pthread.h>
#include <cstdio>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <limits>
#include <mutex>

namespace fs = std::filesystem;

namespace {

// A one-line progress bar on stderr when it is a terminal, otherwise a log
// line every 10 %.
class ProgressBar {
public:
  void operator()(const std::string& label, double fraction) {
    std::lock_guard lock(mutex_);
    const int percent = static_cast<int>(fraction * 100);
    if (isatty(STDERR_FILENO)) {
      if (open_ && percent == shownPercent_ && label == shownLabel_) return;  // (nothing new to draw)
      shownPercent_ = percent, shownLabel_ = label;
      const int filled = static_cast<int>(fraction * 30);
      fmt::print(stderr, "\r[{:<30}] {:3d}% {:<40}", std::string(static_cast<size_t>(filled), '#'), percent,
                 label.substr(0, 40));
      open_ = fraction < 1;
      if (!open_) fmt::print(stderr, "\n");
    } else if (percent / 10 != lastDecile_) {
      lastDecile_ = percent / 10;
      spdlog::info("{:3d}% {}", percent, label);
    }
  }
  ProgressBar() = default;
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;
  ~ProgressBar() {  // (an error unwinding past a bar prints on a line of its own)
    if (open_) std::fputs("\n", stderr);  // (no fmt::print: it may throw, and a destructor must not)
  }
  // Ends a bar left short of 100 % (work stopped early) on its own line.
  void finish() {
    std::lock_guard lock(mutex_);
    if (open_) fmt::print(stderr, "\n");
    open_ = false;
  }

private:
  std::mutex mutex_;
  int lastDecile_ = -1;
  bool open_ = false;  // a terminal's bar line printed without its newline
  int shownPercent_ = -1;
  std::string shownLabel_;
};

// Ctrl-C asks long work to stop cleanly (renders check it between tiles).
std::atomic<bool> gCancel{false};
extern "C" void onInterrupt(int) { gCancel = true; }

// A whole-number option in [lowest, highest], in decimal. (CLI11 2.1's
// PositiveNumber would answer "--spp 0" with "Value 0 not in range 0.000000 to
// 1.797...e308", and its own conversion reads "010" as octal and "-1" as an
// unsigned 2^64 - 1: the validator, a transform, hands it the value in plain
// decimal.)
template <typename T = long long>
CLI::Validator wholeNumberIn(T lowest, T highest) {
  return CLI::Validator(
      [lowest, highest](std::string& input) -> std::string {
        T value = 0;
        const char* end = input.data() + input.size();
        const auto [at, ec] = std::from_chars(input.data(), end, value);
        if (ec != std::errc() || at != end || value < lowest || value > highest)
          return fmt::format("'{}' is not a whole number in [{}, {}]", input, lowest, highest);
        input = std::to_string(value);
        return {};
      },
      fmt::format("INT in [{}, {}]", lowest, highest));
}
constexpr long long kMostThreads = 4096, kMostFrames = 100000, kMostSpp = lfi::sim::kMostSamplesPerPixel;
CLI::Validator threadCount() { return wholeNumberIn(0LL, kMostThreads); }
CLI::Validator seedValue() { return wholeNumberIn<std::uint64_t>(0, lfi::sim::kLargestSeed); }

// The reference bench: next to an installed `lfi` (<prefix>/bin/lfi and
// <prefix>/share/lfi, as `cmake --install` lays them out), else in the source
// tree of the build.
fs::path defaultBench() {
  const fs::path relative = fs::path("benches") / "reference.toml";
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (!ec)
    if (const fs::path installed = self.parent_path().parent_path() / LFI_INSTALL_DATADIR / "lfi" / relative;
        fs::exists(installed, ec))
      return installed;
  return fs::path(LFI_DATA_DIR) / relative;
}

// lfi serve-camera: SimImager frames through Aravis's device-side GigE Vision
// implementation until SIGINT or SIGTERM. The radiance of every binning is
// rendered before the device appears (a render inside a frame would stall the
// device's only thread, which also answers control requests).
void serveCamera(const fs::path& sceneFile, lfi::GvCameraServerOptions options, int threads, bool quiet) {
  // Blocked before any thread starts (the renders' workers, Aravis's device
  // thread inherit the mask), so that SIGINT and SIGTERM reach sigwait() below
  // and not a worker's default action. One that comes during the first
  // renders stops the server as soon as it is up.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  lfi::GvCameraServer::validate(options);  // (before the renders: the serial's length, the interface)
  lfi::sim::SimImager imager(sceneFile);
  ProgressBar bar;
  imager.setRenderOptions(threads, quiet ? std::function<void(double)>() : [&bar](double f) { bar("rendering", f); });
  const int binnings = std::min({lfi::sim::SimImager::limits().maxBinning, imager.camera().width,
                                 imager.camera().height});
  for (int b = 1; b <= binnings; ++b) imager.radiance(b);
  bar.finish();
  imager.setRenderOptions(threads, {});
  options.sensorWidth_px = imager.camera().width;
  options.sensorHeight_px = imager.camera().height;
  const std::string device = "lfi-served:" + sceneFile.string();
  cv::Mat frame;
  lfi::GvCameraServer server(options, [&](const lfi::ServedFrameRequest& request, cv::Mat& image) {
    lfi::CameraSettings s;
    s.exposure_us = request.exposure_us;
    s.gain = request.gain;
    s.pixelFormat = *request.pixelFormat;
    s.binning = request.binning;
    s.roiX_px = request.offsetX_px;
    s.roiY_px = request.offsetY_px;
    s.roiWidth_px = request.width_px;
    s.roiHeight_px = request.height_px;
    s = imager.resolve(s, device);
    imager.capture(s, request.frameId, frame);
    // Into the outgoing buffer: copyTo would reallocate `image` for another size or type, and a black frame go out.
    if (frame.size() != image.size() || frame.type() != image.type())
      lfi::fail(lfi::Errc::Device, "the frame made is {} x {} (type {}), the buffer {} x {} (type {})", frame.cols,
                frame.rows, frame.type(), image.cols, image.rows, image.type());
    frame.copyTo(image);
  });
  fmt::print("{}\n", server.deviceId());
  std::fflush(stdout);
  spdlog::info("serving '{}' as GigE Vision device '{}' on {} ({} x {} px); SIGINT/SIGTERM stops", sceneFile.string(),
               server.deviceId(), options.interfaceAddress, options.sensorWidth_px, options.sensorHeight_px);
  int signal = 0;
  sigwait(&signals, &signal);
  spdlog::info("serve-camera: {} received, stopping", signal == SIGINT ? "SIGINT" : "SIGTERM");
}

// The devices `lfi inspect` and `lfi calibrate-distance` drive, and how.
struct BenchOptions {
  std::string camera, display, capture;
  fs::path lightField;
  int frames = 1;
  double exposure_us = 10'000, gain = 0;
  std::string pixelFormat = "Mono12";
  int settle_ms = 0;
};

void addBenchOptions(CLI::App& command, BenchOptions& o) {
  command.add_option("--camera", o.camera, "Camera URI (aravis:<id>, sim:<scene-file>)")->required();
  command.add_option("--display", o.display, "Display URI (usb:<vid>:<pid>[/<serial>], sim:<scene-file>)")
      ->required();
  auto* capture = command.add_option("--capture", o.capture, "Light field capture URI (sim:<scene-file>[?...])");
  command.add_option("--light-field", o.lightField, "Use this reference light field (EXR) instead of capturing")
      ->check(CLI::ExistingFile)
      ->excludes(capture);
  command.add_option("--frames", o.frames, "Frames averaged per image")->transform(wholeNumberIn(1LL, kMostFrames))
      ->capture_default_str();
  command.add_option("--exposure-us", o.exposure_us, "Exposure time (µs)")->capture_default_str();
  command.add_option("--gain", o.gain, "Gain (device unit, dB for SFNC cameras)")->capture_default_str();
  command.add_option("--pixel-format", o.pixelFormat, "Mono8 | Mono12 | Mono16")
      ->check(CLI::IsMember({"Mono8", "Mono12", "Mono16"}))
      ->capture_default_str();
  command.add_option("--settle-ms", o.settle_ms, "Wait after the display shows a light field before exposing (ms)")
      ->transform(wholeNumberIn(0LL, 24LL * 3600 * 1000))
      ->capture_default_str();
}

// A reference from a file needs no capture device: step 1 is skipped.
class FileCapture final : public lfi::LightFieldCapture {
public:
  explicit FileCapture(fs::path file) : file_(std::move(file)), lf_(lfi::readLightFieldExr(file_)) {}
  lfi::LightFieldGeometry geometry() const override { return lf_.geometry(); }
  lfi::LightField capture(const std::function<void(double)>&) override { return lf_; }
  std::string description() const override { return "file " + file_.string(); }

private:
  fs::path file_;
  lfi::LightField lf_;
};

// The devices opened and the camera configured.
struct OpenBench {
  std::unique_ptr<lfi::Camera> camera;
  std::unique_ptr<lfi::Display> display;
  std::unique_ptr<lfi::LightFieldCapture> capture;  // a device, or FileCapture
  bool captured = false;                            // a device: the reference is a new capture
};

OpenBench openBench(const BenchOptions& o, const char* command) {
  if (o.capture.empty() && o.lightField.empty())
    lfi::fail(lfi::Errc::Config, "{}: give --capture <uri> or --light-field <file>", command);
  lfi::registerDriverBackends();
  lfi::sim::registerSimBackends();
  OpenBench bench;
  bench.camera = lfi::openCamera(o.camera);
  lfi::CameraSettings settings;
  settings.exposure_us = o.exposure_us;
  settings.gain = o.gain;
  settings.pixelFormat = o.pixelFormat == "Mono8"    ? lfi::PixelFormat::Mono8
                         : o.pixelFormat == "Mono16" ? lfi::PixelFormat::Mono16
                                                     : lfi::PixelFormat::Mono12;
  bench.camera->configure(settings);
  bench.display = lfi::openDisplay(o.display);
  bench.captured = !o.capture.empty();
  bench.capture = bench.captured ? lfi::openLightFieldCapture(o.capture) : std::make_unique<FileCapture>(o.lightField);
  return bench;
}

// Makes the folder that --out names (or holds) and checks that files can be
// written into it, before any work: Errc::Io naming the option and the reason.
void requireOutputFolder(const fs::path& folder, const char* command) {
  std::error_code made;
  fs::create_directories(folder, made);
  if (made || !fs::is_directory(folder, made))
    lfi::fail(lfi::Errc::Io, "{}: cannot make the folder '{}' for --out: {}", command, folder.string(),
              made ? made.message() : std::string("a file of that name is in the way"));
  if (::access(folder.c_str(), W_OK | X_OK) != 0)  // (files are made in it: it must be searchable too)
    lfi::fail(lfi::Errc::Io, "{}: cannot write into '{}' for --out: {}", command, folder.string(),
              std::strerror(errno));
}

// Refuses to start when one of `files` exists, unless `force`; Errc::Io when
// that cannot be told (a folder on the way that cannot be searched).
void refuseExisting(const std::vector<fs::path>& files, bool force, const char* command) {
  if (force) return;
  for (const fs::path& file : files) {
    std::error_code ec;
    if (fs::exists(file, ec))
      lfi::fail(lfi::Errc::Exists, "'{}' exists; refusing to overwrite it (use --force to replace it)", file.string());
    if (ec) lfi::fail(lfi::Errc::Io, "{}: cannot look for '{}': {}", command, file.string(), ec.message());
  }
}

// --from, --to and --step as the candidate errors; Errc::Config naming them.
std::vector<double> scanCandidates(double from, double to, double step) {
  const double count = std::isfinite(from) && std::isfinite(to) && step > 0 ? (to - from) / step : -1;
  // (Whole steps within rounding: 0.1 to 0.3 by 0.1 is 1.9999999999999998 steps.)
  if (!(std::round(count) >= 2 && std::round(count) <= 1000) || !(std::abs(count - std::round(count)) <= 1e-6))
    lfi::fail(lfi::Errc::Config,
              "calibrate-distance: --from {} --to {} --step {} must give 3 to 1001 candidates, the range a whole "
              "number of steps", from, to, step);
  std::vector<double> candidates;
  for (int i = 0; i <= static_cast<int>(std::round(count)); ++i) candidates.push_back(from + i * step);
  return candidates;
}

// lfi calibrate-distance: the display-to-part distance scan (docs/calibration.md).
void calibrateDistance(const BenchOptions& o, const std::vector<double>& candidates, const std::vector<int>& roiBox,
                       const fs::path& out, bool force, bool quiet) {
  const auto overwrite = force ? lfi::Overwrite::Allow : lfi::Overwrite::Refuse;
  if (std::error_code ec; out.filename().empty() || fs::is_directory(out, ec))
    lfi::fail(lfi::Errc::InvalidArgument, "calibrate-distance: --out '{}' must name a file, not a folder",
              out.string());
  // A captured reference is kept beside the scan (scan.json: scan.lightfield.exr), as `inspect` keeps its own.
  const fs::path referenceFile = fs::path(out).replace_extension(".lightfield.exr");
  std::vector<fs::path> outputs{out};
  if (!o.capture.empty()) outputs.push_back(referenceFile);
  refuseExisting(outputs, force, "calibrate-distance");
  OpenBench bench = openBench(o, "calibrate-distance");
  // Where the result goes must take it before the scan, not after (and a bad device leaves no folder behind).
  requireOutputFolder(out.parent_path().empty() ? fs::path(".") : out.parent_path(), "calibrate-distance");
  const lfi::CameraSettings settings = bench.camera->settings();
  cv::Mat roi;
  if (!roiBox.empty()) {
    const cv::Rect box(roiBox[0], roiBox[1], roiBox[2], roiBox[3]);
    if (box.x < 0 || box.y < 0 || box.width < 1 || box.height < 1 || box.width > settings.roiWidth_px - box.x ||
        box.height > settings.roiHeight_px - box.y)
      lfi::fail(lfi::Errc::Config, "calibrate-distance: --roi {},{},{},{} is not inside the camera's {} x {} image",
                box.x, box.y, box.width, box.height, settings.roiWidth_px, settings.roiHeight_px);
    roi = cv::Mat::zeros(settings.roiHeight_px, settings.roiWidth_px, CV_8UC1);
    roi(box).setTo(255);
  }
  lfi::ControllerOptions options;
  options.frames = o.frames;
  options.settle = std::chrono::milliseconds(o.settle_ms);
  // The candidates against the reference's distance before a capture, not after it.
  lfi::calib::checkDisplayDistanceCandidates(bench.capture->geometry(), candidates);
  lfi::Controller controller(*bench.capture, *bench.display, *bench.camera, options);
  ProgressBar bar;
  const lfi::LightField reference = controller.captureReference([&](const char* step, double f) {
    if (!quiet) bar(step, f);
  });
  if (bench.captured) lfi::writeLightFieldExr(referenceFile, reference, overwrite);
  // One drive scale for every candidate: the brightness compares the display's position, not the fields' peaks.
  const double white = lfi::Controller::defaultWhite(reference);
  size_t done = 0;
  const size_t images = candidates.size() + 3;  // and two with the display dark, and the brightest again
  lfi::calib::DisplayDistanceScan scan;
  try {
    scan = lfi::calib::calibrateDisplayDistance(
        reference,
        [&](const lfi::LightField& shown) {
          if (!quiet) bar(fmt::format("image {} of {}", done + 1, images), static_cast<double>(done) / images);
          ++done;
          controller.emit(shown, white);
          return controller.inspect();
        },
        candidates, roi, 1 / std::sqrt(12.0));  // a digital number's quantisation (alike frames keep it)
  } catch (const lfi::Error& e) {
    if (!bench.captured) throw;
    throw lfi::Error(e.code(), fmt::format("{} (the captured reference is kept: --light-field {} scans again "
                                           "without capturing)", e.what(), referenceFile.string()));
  }
  if (!quiet) bar("scan", 1);
  bar.finish();
  // The table first: should the file fail to be written, the scan is not lost.
  fmt::print("with the display dark: {:.6g} (noise of a mean {:.2g})\n", scan.dark, scan.noise);
  for (size_t i = 0; i < scan.candidates_mm.size(); ++i)
    fmt::print("{:+8.3f} mm  {:.6g}\n", scan.candidates_mm[i], scan.brightness[i]);
  fmt::print("estimate {:+.3f} mm (the display {:.3f} mm {} the part than the reference's {} mm)\n",
             scan.estimate_mm, std::abs(scan.estimate_mm), scan.estimate_mm >= 0 ? "further from" : "nearer to",
             reference.geometry().distance_mm);
  const lfi::CameraInfo camera = bench.camera->info();
  nlohmann::ordered_json result;
  result["format"] = "lfi-display-distance-scan";
  result["version"] = 1;
  result["units"] = "mm; brightness in the camera's digital numbers";
  result["convention"] =
      "epsilon > 0: the display is further from the part than the reference light field's distance_mm; the "
      "estimate is the centre of the brightness peak, half-way between where it falls below `level` on either "
      "side (docs/calibration.md)";
  result["reference"] = {{"source", bench.capture->description()},
                         {"file", fs::absolute(bench.captured ? referenceFile : o.lightField).string()},
                         {"distance_mm", reference.geometry().distance_mm}};
  result["camera"] = {{"uri", o.camera},
                      {"vendor", camera.vendor},
                      {"model", camera.model},
                      {"serial", camera.serial},
                      {"exposure_us", settings.exposure_us},
                      {"gain", settings.gain},
                      {"pixel_format", o.pixelFormat},
                      {"binning", settings.binning},
                      {"frames", o.frames},
                      {"settle_ms", o.settle_ms}};
  result["display"] = {{"uri", o.display}, {"white", white}};
  result["roi_px"] = roiBox.empty() ? nlohmann::ordered_json(nullptr) : nlohmann::ordered_json(roiBox);
  result["dark"] = scan.dark;
  result["noise"] = scan.noise;
  result["dark_noise"] = scan.darkNoise;
  result["candidates_mm"] = scan.candidates_mm;
  result["brightness"] = scan.brightness;
  result["level"] = scan.level;
  result["estimate_mm"] = scan.estimate_mm;
  result["peak_width_mm"] = scan.width_mm;
  // Device strings and paths need not be UTF-8: replace what is not.
  lfi::writeFileAtomically(out, overwrite,
                           result.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) + "\n");
  fmt::print("{}\n", out.string());
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"lfi: inverse schlieren inspection bench (drivers and ray-traced simulation)"};
  app.set_version_flag("--version", LFI_VERSION);
  app.require_subcommand(1);
  int verbosity = 0;
  auto* verbose = app.add_flag("-v,--verbose", verbosity, "More log output (repeat for more)");
  bool quiet = false;
  app.add_flag("-q,--quiet", quiet, "Only errors on stderr")->excludes(verbose);

  // lfi study
  auto* study = app.add_subcommand("study", "Run the reference study on the simulated bench");
  fs::path studyOut;
  fs::path benchFile = defaultBench();
  std::string quality = "default";
  bool force = false;
  int threads = 0;
  std::uint64_t seed = 1;
  study->add_option("--out", studyOut, "Output folder (study.json, images/, report.html)")->required();
  study->add_option("--bench", benchFile, "Bench file (TOML)")->check(CLI::ExistingFile)->capture_default_str();
  study->add_option("--quality", quality, "quick | default | high")
      ->check(CLI::IsMember({"quick", "default", "high"}))
      ->capture_default_str();
  study->add_option("--threads", threads, "Worker threads (0 = all cores)")->transform(threadCount());
  study->add_option("--seed", seed, "Random seed (renders and sensor noise)")
      ->transform(seedValue())
      ->capture_default_str();
  study->add_flag("--force", force, "Replace the results of an earlier study in --out");
  bool sweepOn = false, sweepOff = false;
  auto* sweepFlag =
      study->add_flag("--sweep", sweepOn, "Run the display-quality sweep (default: on, except with --quality quick)");
  study->add_flag("--no-sweep", sweepOff, "Skip the display-quality sweep")->excludes(sweepFlag);

  // lfi render
  auto* render = app.add_subcommand("render", "Render a scene file (camera image or light field)");
  fs::path sceneFile, renderOut;
  int spp = 0;
  bool renderForce = false;
  int renderThreads = 0;
  render->add_option("scene", sceneFile, "Scene file (TOML, docs/scene-files.md)")
      ->required()
      ->check(CLI::ExistingFile);
  render->add_option("--out", renderOut, "Output folder")->required();
  render->add_option("--spp", spp, "Samples per pixel (overrides the scene file)")
      ->transform(wholeNumberIn(1LL, kMostSpp));
  render->add_option("--threads", renderThreads, "Worker threads (0 = all cores)")->transform(threadCount());
  std::optional<std::uint64_t> renderSeed;
  render->add_option("--seed", renderSeed, "Random seed (overrides the scene file)")->transform(seedValue());
  render->add_flag("--force", renderForce, "Replace existing output files");

  // lfi serve-camera
  auto* serve = app.add_subcommand(
      "serve-camera", "Serve the ray-traced camera of a scene file as a GigE Vision device (Ctrl-C stops)");
  fs::path serveScene;
  lfi::GvCameraServerOptions serveOptions;
  int serveThreads = 0;
  serve->add_option("scene", serveScene, "Scene file with a [camera] (TOML, docs/scene-files.md)")
      ->required()
      ->check(CLI::ExistingFile);
  serve->add_option("--interface", serveOptions.interfaceAddress, "IPv4 address or network interface to serve on")
      ->capture_default_str();
  serve->add_option("--serial", serveOptions.serial, "Serial number (device id: lfi-SimCamera-<serial>)")
      ->capture_default_str();
  serve->add_option("--threads", serveThreads, "Render threads (0 = all cores)")->transform(threadCount());

  // lfi inspect
  auto* inspect = app.add_subcommand(
      "inspect", "Capture the reference light field, emit it with the display, inspect through the camera");
  BenchOptions inspectBench;
  fs::path inspectOut;
  bool inspectForce = false;
  addBenchOptions(*inspect, inspectBench);
  inspect->add_option("--out", inspectOut, "Output folder (inspection.exr/.png, lightfield.exr)")->required();
  inspect->add_flag("--force", inspectForce, "Replace existing output files");

  // lfi calibrate-distance
  auto* calibrate = app.add_subcommand(
      "calibrate-distance", "Scan the display-to-part distance error by showing the reference light field "
      "propagated to candidate distances (docs/calibration.md)");
  BenchOptions calibrateBench;
  double scanFrom = -6, scanTo = 6, scanStep = 1;
  std::vector<int> roiBox;
  fs::path calibrateOut;
  bool calibrateForce = false;
  addBenchOptions(*calibrate, calibrateBench);
  calibrate->add_option("--from", scanFrom, "First candidate error (mm)")->capture_default_str();
  calibrate->add_option("--to", scanTo, "Last candidate error (mm)")->capture_default_str();
  calibrate->add_option("--step", scanStep, "Candidate spacing (mm)")->capture_default_str();
  calibrate->add_option("--roi", roiBox, "The part's pixels in the camera image: x,y,width,height (default: all)")
      ->delimiter(',')
      ->expected(4);
  calibrate->add_option("--out", calibrateOut, "Result file (JSON)")->required();
  calibrate->add_flag("--force", calibrateForce,
                      "Replace an existing result file, and the captured reference kept beside it (scan.json: "
                      "scan.lightfield.exr)");

  // lfi lf-info
  auto* lfInfo = app.add_subcommand("lf-info", "Validate a light field EXR and print its parametrisation");
  fs::path lfFile;
  lfInfo->add_option("file", lfFile, "Light field EXR")->required();

  // lfi devices
  auto* devices = app.add_subcommand("devices", "List the GenICam cameras and USB displays attached, with their URIs");

  CLI11_PARSE(app, argc, argv);
  lfi::initLogging(quiet ? -1 : verbosity);

  try {
    if (*study) {
      const lfi::study::Bench bench = lfi::study::Bench::load(benchFile);
      lfi::study::StudyOptions options;
      options.quality = lfi::study::parseQuality(quality);
      options.threads = threads;
      lfi::setExrThreads(threads);  // (the light fields and images it writes)
      options.seed = seed;
      options.overwrite = force;
      if (sweepOn) options.sweep = lfi::study::defaultSweep();
      if (sweepOff) options.sweep = std::vector<lfi::study::SweepPoint>{};
      ProgressBar bar;
      if (!quiet) options.progress = [&bar](const std::string& label, double f) { bar(label, f); };
      const auto start = std::chrono::steady_clock::now();
      const auto result = lfi::study::runStudy(bench, studyOut, options);
      bar.finish();
      fmt::print("{}", lfi::study::verdictTable(result));
      spdlog::info("study written to {} in {:.1f} s (open {})", studyOut.string(),
                   std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
                   (studyOut / "report.html").string());
    } else if (*render) {
      lfi::sim::SceneDescription d = lfi::sim::loadSceneFile(sceneFile);
      if (spp > 0) d.render.samplesPerPixel = spp;
      if (renderSeed) d.render.seed = *renderSeed;
      d.render.threads = renderThreads;
      lfi::setExrThreads(renderThreads);
      d.render.cancel = &gCancel;
      ProgressBar bar;
      if (!quiet) d.render.progress = [&bar](double f) { bar("rendering", f); };
      // (A run started with SIGINT ignored, as a background job is, keeps it ignored.)
      const auto previousSigint = std::signal(SIGINT, SIG_IGN);
      if (previousSigint != SIG_IGN) std::signal(SIGINT, onInterrupt);
      // Where the images go must take them before the render, not after.
      const auto overwrite = renderForce ? lfi::Overwrite::Allow : lfi::Overwrite::Refuse;
      const bool lightField = std::holds_alternative<lfi::sim::LightFieldSensor>(d.sensor);
      const std::vector<fs::path> outputs =
          lightField ? std::vector<fs::path>{renderOut / (d.name + "_lightfield.exr")}
                     : std::vector<fs::path>{renderOut / (d.name + ".exr"), renderOut / (d.name + ".png")};
      requireOutputFolder(renderOut, "render");
      refuseExisting(outputs, renderForce, "render");
      const lfi::sim::Scene scene(std::move(d.objects), d.ambientIor);
      const auto start = std::chrono::steady_clock::now();
      cv::Mat image;
      try {
        image = lfi::sim::render(scene, d.sensor, d.render);
      } catch (const lfi::Error& e) {  // the scene cannot be traced (e.g. too deeply nested): name its file
        if (e.code() != lfi::Errc::Config) throw;
        throw lfi::Error(e.code(), fmt::format("{}: {}", sceneFile.string(), e.what()));
      }
      // From here Ctrl-C does what it did before (by default: ends the process; a write in progress removes its
      // temporary): the render it would have cancelled is done.
      std::signal(SIGINT, previousSigint == SIG_ERR ? SIG_DFL : previousSigint);
      if (gCancel) lfi::fail(lfi::Errc::Cancelled, "render: interrupted");
      const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      bar.finish();
      if (const auto* lfs = std::get_if<lfi::sim::LightFieldSensor>(&d.sensor)) {
        lfi::writeLightFieldExr(outputs[0], lfi::LightField(lfs->geometry, image), overwrite);
        fmt::print("{}\n", outputs[0].string());
      } else {
        const auto& cam = std::get<lfi::sim::TelecentricCamera>(d.sensor);
        lfi::writeRadianceExr(outputs[0], image, {cam.objectPixel_mm(), "rendered radiance of scene " + d.name},
                              overwrite);
        lfi::writePngAtomically(outputs[1], lfi::toneMapForDisplay(image), overwrite);
        fmt::print("{}\n{}\n", outputs[0].string(), outputs[1].string());
      }
      const double samples = static_cast<double>(image.total()) * d.render.samplesPerPixel;
      spdlog::info("{:.0f} samples in {:.3f} s: {:.2f} M samples/s", samples, seconds, samples / seconds / 1e6);
    } else if (*inspect) {
      const auto overwrite = inspectForce ? lfi::Overwrite::Allow : lfi::Overwrite::Refuse;
      std::vector<fs::path> outputs{inspectOut / "inspection.exr", inspectOut / "inspection.png"};
      if (!inspectBench.capture.empty())  // (a given light field is not written)
        outputs.push_back(inspectOut / "lightfield.exr");
      refuseExisting(outputs, inspectForce, "inspect");
      OpenBench bench = openBench(inspectBench, "inspect");
      lfi::ControllerOptions options;
      options.frames = inspectBench.frames;
      options.settle = std::chrono::milliseconds(inspectBench.settle_ms);
      ProgressBar bar;
      lfi::Controller controller(*bench.capture, *bench.display, *bench.camera, options);
      requireOutputFolder(inspectOut, "inspect");  // (once the devices are open: a bad one leaves no folder)
      const lfi::LightField reference = controller.captureReference([&](const char* step, double f) {
        if (!quiet) bar(step, f);
      });
      bar.finish();
      if (bench.captured) lfi::writeLightFieldExr(inspectOut / "lightfield.exr", reference, overwrite);
      try {  // (whatever fails from here on, a captured light field is kept and named)
        controller.emit(reference);
        const cv::Mat image = controller.inspect();
        const auto info = bench.camera->info();
        lfi::writeRadianceExr(inspectOut / "inspection.exr", image,
                              {0,
                               fmt::format("inspection image (DN, mean of {} frames) from {} {} via {}",
                                           inspectBench.frames, info.vendor, info.model, inspectBench.camera),
                               lfi::kCameraDigitalNumbers},
                              overwrite);
        double maxValue = 0;
        cv::minMaxLoc(image, nullptr, &maxValue);
        cv::Mat png8;
        image.convertTo(png8, CV_8U, maxValue > 0 ? 255.0 / maxValue : 1.0);
        lfi::writePngAtomically(inspectOut / "inspection.png", png8, overwrite);
      } catch (const lfi::Error& e) {
        if (!bench.captured) throw;
        throw lfi::Error(e.code(),
                         fmt::format("{} (the captured light field is kept: rerun with --light-field {} to skip the "
                                     "capture)", e.what(), (inspectOut / "lightfield.exr").string()));
      }
      if (bench.captured) fmt::print("{}\n", (inspectOut / "lightfield.exr").string());
      fmt::print("{}\n{}\n", (inspectOut / "inspection.exr").string(), (inspectOut / "inspection.png").string());
    } else if (*calibrate) {
      calibrateDistance(calibrateBench, scanCandidates(scanFrom, scanTo, scanStep), roiBox, calibrateOut,
                        calibrateForce, quiet);
    } else if (*serve) {
      lfi::setExrThreads(serveThreads);
      serveCamera(serveScene, serveOptions, serveThreads, quiet);
    } else if (*devices) {
      // Displays first: their listing is instant, the cameras' discovery waits about 1 s for answers.
      bool listed = true;  // (exit status 1 when the displays could not be listed, after the cameras)
      try {                // a machine without USB still has cameras to list
        const std::vector<lfi::UsbDisplayInfo> displays = lfi::listUsbDisplays();
        fmt::print("USB displays: {}\n", displays.empty() ? "none" : std::to_string(displays.size()));
        for (const lfi::UsbDisplayInfo& d : displays)
          fmt::print("  {}  (bus {:03d} device {:03d}){}\n", d.selector.uri(), d.bus, d.address,
                     d.problem.empty() ? "" : ": " + d.problem);
      } catch (const lfi::Error& e) {
        fmt::print("USB displays: cannot be listed ({})\n", e.what());
        listed = false;
      }
      const std::vector<lfi::AravisDeviceInfo> cameras = lfi::listAravisDevices();
      fmt::print("GenICam cameras: {}\n", cameras.empty() ? "none" : std::to_string(cameras.size()));
      for (const lfi::AravisDeviceInfo& c : cameras)
        fmt::print("  aravis:{}  ({} {}, serial {}, {} at {})\n", lfi::percentEncodeUriPart(c.id), c.vendor, c.model,
                   c.serial, c.protocol,
                   c.address);
      if (!listed) return 1;
    } else if (*lfInfo) {
      const lfi::LightField lf = lfi::readLightFieldExr(lfFile);
      const auto& g = lf.geometry();
      fmt::print("{}: valid light field\n  spatial {} x {} elements of {} x {} angular elements\n"
                 "  pixel pitch {} mm, element pitch {} mm, extent {} x {} mm, distance {} mm\n",
                 lfFile.string(), g.spatialX, g.spatialY, g.angular, g.angular, g.pixelPitch_mm, g.elementPitch_mm(),
                 g.extentX_mm(), g.extentY_mm(), g.distance_mm);
    }
  } catch (const lfi::Error& e) {
    spdlog::error("{}", e.what());
    return e.code() == lfi::Errc::Cancelled ? 130 : 1;
  } catch (const std::exception& e) {
    spdlog::error("unexpected failure: {}", e.what());
    return 2;
  }
  return 0;
}
