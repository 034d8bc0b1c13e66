// SPDX-License-Identifier: Apache-2.0
// lfi calibrate display|part|camera BENCH: the display's lens array and the
// camera's scale (nothing in view), Δ, the part's place and the display's gap
// (through the intact part, against its model), or the camera's scale on a
// chessboard target, measured with the bench's own devices
// (docs/calibration.md) and written into the bench file with a backup and a
// record, or printed with --dry-run.

#include "bench_cli.h"
#include "cli_util.h"
#include "commands.h"

#include "lfi/controller/bench_devices.h"
#include "lfi/controller/camera_calibration.h"
#include "lfi/controller/display_calibration.h"
#include "lfi/controller/exposure_calibration.h"
#include "lfi/controller/frame_correction.h"
#include "lfi/controller/inspection_record.h"
#include "lfi/controller/panel_calibration.h"
#include "lfi/controller/part_calibration.h"
#include "lfi/core/error.h"
#include "lfi/core/log.h"
#include "lfi/sim/scene_part_model.h"

#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <memory>
#include <optional>

namespace fs = std::filesystem;

namespace lfi::cli {

namespace {

// Frames averaged into a dark or flat frame: its own noise, added to every
// corrected image, is then 1/sqrt(64) = 1/8 of one frame's.
constexpr int kFrameCalibrationFrames = 64;

struct CalibrateArgs {
  std::string what;
  fs::path bench;
  fs::path part;   // a simulated bench's scene during the calibration
  fs::path model;  // the part's model (part)
  bool dryRun = false;
  int frames = 0;                   // 0: the bench's [inspection] frames
  std::string corners;              // camera: the chessboard's inner corners, COLSxROWS
  double square_mm = 0;             // camera: its squares' side
  bool dark = false, flat = false;  // camera: the dark or the flat frame
  lfi::DisplayCalibrationSettings settings;
  lfi::PartCalibrationSettings partSettings;
  lfi::CameraCalibrationSettings cameraSettings;
  lfi::PanelCalibrationSettings panelSettings;
  lfi::ExposureCalibrationSettings exposureSettings;
};

void printDisplayCalibration(const lfi::DisplayCalibration& c) {
  const double k = c.coverageFactor;
  const calib::CameraScaleFit& m = c.camera;
  const lfi::DisplayOpticsParams& stated = c.nominal.optics;
  if (lfi::fullParallax(c.optics.type)) {
    const calib::LatticeFit& l = c.lattice;
    fmt::print("display {} ({} {}), {} array: {} lens centres ({} left out), residual {:.2g} mm\n", c.nominal.deviceId,
               c.nominal.vendor, c.nominal.model, toString(c.optics.type), l.centres, l.outliers, l.residualRms_mm);
    fmt::print("  pitch      {:.6f} mm    U {:.2g} mm   (stated {:.6f})\n", l.pitch_mm, k * l.pitchSigma_mm,
               stated.arrayPitch_mm);
    fmt::print("  rotation   {:+.6f} rad  U {:.2g} rad  (stated {:+.6f})\n", l.rotation_rad, k * l.rotationSigma_rad,
               stated.rotation_rad);
    fmt::print("  offset     [{:+.5f}, {:+.5f}] mm  U [{:.2g}, {:.2g}] mm  (stated [{:+.5f}, {:+.5f}])\n",
               l.offset_mm.x, l.offset_mm.y, k * l.offsetSigma_mm.x, k * l.offsetSigma_mm.y, stated.arrayOffsetX_mm,
               stated.arrayOffsetY_mm);
  } else {
    const calib::AxisFit& a = c.axes;
    fmt::print("display {} ({} {}), {}: {} lens axes from {} points ({} left out), residual {:.2g} px\n",
               c.nominal.deviceId, c.nominal.vendor, c.nominal.model, toString(c.optics.type), a.axes, a.points,
               a.outliers, a.residualRms_px);
    fmt::print("  lens pitch {:.5f} px    U {:.2g} px   (stated {:.5f})\n", a.pitch_px, k * a.pitchSigma_px,
               stated.lensPitch_px);
    fmt::print("  slant      {:+.6f} rad  U {:.2g} rad  (stated {:+.6f})\n", a.slant_rad, k * a.slantSigma_rad,
               stated.slant_rad);
    fmt::print("  offset     {:+.4f} px    U {:.2g} px   (stated {:+.4f})\n", a.offset_px, k * a.offsetSigma_px,
               stated.offset_px);
    if (c.optics.type == lfi::OpticsType::LineBarrier)
      fmt::print("  slit width {:.5f} mm    U {:.2g} mm   (stated {:.5f})\n", c.optics.slitWidth_mm,
                 k * c.slitWidthSigma_mm, stated.slitWidth_mm);
  }
  fmt::print("camera: {} points, residual {:.2g} mm\n", c.spots, m.residualRms_mm);
  fmt::print("  object pixel  {:.6f} mm  U {:.2g} mm  (along a row {:.6f}, down a column {:.6f})\n", m.objectPixel_mm,
             k * m.objectPixelSigma_mm, m.pixelX_mm, m.pixelY_mm);
  fmt::print("  rotation {:+.5f} rad{}; the image's centre sees the display at [{:+.4f}, {:+.4f}] mm\n", m.rotation_rad,
             m.mirrored ? ", mirrored" : "", m.map.atImageCentre_mm.x, m.map.atImageCentre_mm.y);
  fmt::print("  distortion at the corner {:+.3f} px  U {:.2g} px (reported, not applied)\n", m.distortion_px,
             k * m.distortionSigma_px);
  fmt::print("U: expanded uncertainty, k = {:g}; {} frames in {:.2f} s ({:.0f} ms of it decoding and fitting)\n", k,
             c.frames, c.seconds, 1000 * c.computeSeconds);
}

void printPartCalibration(const lfi::PartCalibration& c) {
  const double k = c.coverageFactor;
  fmt::print(
      "display {} ({} {}), through the part: {} camera pixels in the fit ({} left out), offsets' residual "
      "{:.2g} mm, {} rays in another lens\n",
      c.nominal.deviceId, c.nominal.vendor, c.nominal.model, c.pixels, c.outliers, c.offsetRms_mm, c.otherLens);
  fmt::print("  Δ          {:.4f} mm  U {:.2g} mm  (stated {:.4f})\n", c.distance_mm, k * c.distanceSigma_mm,
             c.statedDistance_mm);
  if (c.lateralMeasured)
    fmt::print("  lateral    [{:+.4f}, {:+.4f}] mm  U [{:.2g}, {:.2g}] mm: the part's centre at [{:.2f}, {:.2f}] px\n",
               c.lateral_mm.x, c.lateral_mm.y, k * c.lateralSigma_mm.x, k * c.lateralSigma_mm.y, c.partCentre_px.x,
               c.partCentre_px.y);
  else
    fmt::print(
        "  lateral    [{:+.4f}, {:+.4f}] mm, moved only across the lens axes (the bench's part_centre_px kept)\n",
        c.lateral_mm.x, c.lateral_mm.y);
  fmt::print("  gap        {:.5f} mm  U {:.2g} mm  (stated {:.5f})\n", c.gap_mm, k * c.gapSigma_mm,
             c.nominal.optics.gap_mm);
  fmt::print("U: expanded uncertainty, k = {:g}; {} frames in {:.2f} s ({:.0f} ms of it decoding and fitting)\n", k,
             c.frames, c.seconds, 1000 * c.computeSeconds);
}

void printPanelCalibration(const lfi::PanelCalibration& c) {
  const double k = c.coverageFactor;
  const auto& r = c.response;
  fmt::print(
      "display {} ({} {}), through the camera with {} pixels on the panel: {:.1f} DN from dark to full, "
      "the noise of a mean {:.2g} DN\n",
      c.display.deviceId, c.display.vendor, c.display.model, c.pixels, c.fullLight_dn, c.meanNoise_dn);
  const std::size_t curves = r.light.size();
  fmt::print("  level {}\n", curves == 1 ? "  light      U" : "  red        U       green      U       blue       U");
  for (std::size_t j = 0; j < r.levels.size(); ++j) {
    fmt::print("  {:5g}", r.levels[j]);
    for (std::size_t i = 0; i < curves; ++i) fmt::print("   {:.5f}  {:.1e}", r.light[i][j], k * c.lightSigma[i][j]);
    fmt::print("\n");
  }
  const lfi::PanelResponse response(r, c.display);
  const int w = c.display.panelWidth_px - 1, h = c.display.panelHeight_px - 1;
  fmt::print("  backlight at the corners {:.3f} {:.3f} {:.3f} {:.3f} of the centre's (the fit's residual {:.2g})\n",
             response.backlight(0, 0), response.backlight(w, 0), response.backlight(0, h), response.backlight(w, h),
             c.backlightResidual);
  fmt::print("U: expanded uncertainty, k = {:g}; {} frames in {:.2f} s\n", k, c.frames, c.seconds);
}

void printCameraCalibration(const lfi::CameraCalibration& c, const lfi::BenchFile& bench) {
  const double k = c.coverageFactor;
  const calib::CameraScaleFit& m = c.camera;
  fmt::print("camera on a chessboard of {}: {} corners, residual {:.2g} mm\n", c.target.describe(), m.points,
             m.residualRms_mm);
  fmt::print("  object pixel  {:.6f} mm  U {:.2g} mm  (stated {:.6f})\n", m.objectPixel_mm, k * m.objectPixelSigma_mm,
             bench.objectPixel_mm);
  fmt::print("  along a row {:.6f} mm, down a column {:.6f} mm\n", m.pixelX_mm, m.pixelY_mm);
  if (bench.cameraOnDisplay) {
    const double onDisplay = bench.cameraOnDisplay->objectPixel_mm();
    fmt::print("  the display calibration's scale in the bench: {:.6f} mm ({:+.3f} % against the target's)\n",
               onDisplay, 100 * (onDisplay / m.objectPixel_mm - 1));
  }
  fmt::print("  distortion at the corner {:+.3f} px  U {:.2g} px (reported, not applied)\n", m.distortion_px,
             k * m.distortionSigma_px);
  fmt::print(
      "U: expanded uncertainty, k = {:g}; {} frame in {:.2f} s ({:.0f} ms of it finding the corners and fitting)\n", k,
      c.frames, c.seconds, 1000 * c.computeSeconds);
}

// lfi calibrate camera --dark | --flat: the frame taken through the bench
// without a correction, checked with the bench's dark frame (a flat one) or
// flat frame (a dark one: a flat that no longer fits it leaves the bench),
// written beside the bench file and named in it.
int runCalibrateFrame(const CalibrateArgs& a, const GlobalOptions& global) {
  using lfi::CalibrationFrameKind;
  const CalibrationFrameKind kind = a.dark ? CalibrationFrameKind::Dark : CalibrationFrameKind::Flat;
  const lfi::BenchFile bench = lfi::readBenchFile(a.bench);
  lfi::BenchFileEdit edit(a.bench);
  std::optional<lfi::CalibrationFrame> other;  // the bench's frame of the other kind
  if (kind == CalibrationFrameKind::Flat) {
    if (bench.darkFrame.empty())
      lfi::fail(lfi::Errc::Config,
                "{}: [camera] dark_frame is not set: a flat frame is corrected by the dark one; take it first (lfi "
                "calibrate camera {} --dark)",
                a.bench.string(), a.bench.string());
    other = lfi::readCalibrationFrame(bench.darkFrame, CalibrationFrameKind::Dark);
  } else if (!bench.flatFrame.empty()) {
    other = lfi::readCalibrationFrame(bench.flatFrame, CalibrationFrameKind::Flat);
  }
  const lfi::BenchFile devices = a.part.empty() ? bench : withSimulatedPart(bench, a.part);
  auto display = lfi::openBenchDisplay(devices);
  auto camera = lfi::openBenchCamera(devices, lfi::BenchExposures::OnRequest);
  lfi::NoCapture noCapture;
  const int frames = a.frames > 0 ? a.frames : kFrameCalibrationFrames;
  lfi::Controller controller(noCapture, *display, *camera, lfi::controllerOptions(bench, frames, false));
  const auto t0 = std::chrono::steady_clock::now();
  lfi::CalibrationFrame frame =
      lfi::takeCalibrationFrame(controller.probe(), kind, camera->info().deviceId, camera->settings(), frames);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const std::string stamp = lfi::utcNow();
  const fs::path file = lfi::calibrationFile(a.bench, stamp, lfi::toString(kind), ".exr");
  frame.file = file;
  std::optional<lfi::FrameCorrection> correction;
  if (kind == CalibrationFrameKind::Flat) {
    correction.emplace(*other, frame);  // the flat frame's refusals
  } else {
    correction.emplace(frame, std::nullopt);
    if (other) try {
        lfi::FrameCorrection kept(frame, *other);
      } catch (const lfi::Error& e) {
        spdlog::warn(
            "calibrate: the bench's flat frame does not fit the new dark frame, and leaves the bench ({}): "
            "take it again (lfi calibrate camera {} --flat)",
            e.what(), a.bench.string());
        edit.remove("camera", "flat_frame");
      }
  }
  cv::Scalar mean, sigma;
  cv::meanStdDev(frame.image, mean, sigma);
  fmt::print("{} frame of camera {}: {} x {} px, the mean of {} frames in {:.2f} s: {:.2f} DN, spread {:.2f} DN\n",
             lfi::toString(kind), frame.camera, frame.image.cols, frame.image.rows, frames, seconds, mean[0], sigma[0]);
  if (kind == CalibrationFrameKind::Flat) {
    double least = 0, most = 0;
    cv::minMaxLoc(correction->gain(), &least, &most);
    fmt::print("  response relative to the median pixel's: {:.3f} .. {:.3f}\n", 1 / most, 1 / least);
  }
  lfi::setCalibrationFrame(edit, kind, file, stamp);
  if (a.dryRun) {
    fmt::print("--dry-run: {} would change:\n{}", a.bench.string(), edit.changes());
    return 0;
  }
  const std::string record =
      lfi::calibrationFrameRecord(*correction, kind, bench, stamp, lfi::describeCamera(*camera, bench.cameraUri));
  std::error_code ec;
  fs::create_directories(file.parent_path(), ec);
  if (ec)
    lfi::fail(lfi::Errc::Io, "cannot create the calibration folder '{}': {}", file.parent_path().string(),
              ec.message());
  lfi::writeCalibrationFrame(file, frame);
  try {
    const lfi::PublishedCalibration published = lfi::publishCalibration(edit, lfi::toString(kind), stamp, record);
    spdlog::info("calibrate: {} written with the {} frame {}; the file before is {}, the record {}", a.bench.string(),
                 lfi::toString(kind), file.string(), published.backup.string(), published.record.string());
  } catch (...) {
    fs::remove(file, ec);  // no frame of a calibration not applied
    throw;
  }
  spdlog::info(
      "calibrate: the reference package depends on the camera's correction: take it again (lfi capture {} "
      "--force)",
      a.bench.string());
  fmt::print("{}\n", a.bench.string());
  return 0;
}

// lfi calibrate exposure: the camera reconfigured round by round, outside one controller.
int runCalibrateExposure(const CalibrateArgs& a, const GlobalOptions& global) {
  const lfi::BenchFile bench = lfi::readBenchFile(a.bench);
  lfi::BenchFileEdit edit(a.bench);
  const lfi::BenchFile devices = a.part.empty() ? bench : withSimulatedPart(bench, a.part);
  auto display = lfi::openBenchDisplay(devices);
  auto camera = lfi::openBenchCamera(devices, lfi::BenchExposures::OnRequest);
  ProgressBar bar;
  const lfi::ExposureCalibration c =
      lfi::calibrateExposure(*camera, *display, camera->settings(),
                             lfi::controllerOptions(bench, a.frames > 0 ? a.frames : bench.inspectionFrames, false),
                             a.exposureSettings, [&](double f) {
                               if (!global.quiet) bar("calibrate exposure", f);
                             });
  bar.finish();
  fmt::print(
      "camera {}: exposure {:.6g} us (was {:.6g}): the brightest pixels (99.9th percentile) at {:.1f} DN of "
      "{:g} over a dark of {:.1f} DN, in {} rounds, {:.2f} s\n",
      camera->info().deviceId, c.exposure_us, c.startExposure_us, c.brightest_dn + c.dark_dn, c.fullScale_dn, c.dark_dn,
      c.rounds, c.seconds);
  const std::string stamp = lfi::utcNow();
  lfi::setExposureCalibration(edit, c, a.exposureSettings.fraction, stamp);
  if (a.dryRun) {
    fmt::print("--dry-run: {} would change:\n{}", a.bench.string(), edit.changes());
    return 0;
  }
  const lfi::PublishedCalibration published =
      lfi::publishCalibration(edit, "exposure", stamp,
                              lfi::exposureCalibrationRecord(c, a.exposureSettings.fraction, bench, stamp,
                                                             lfi::describeCamera(*camera, bench.cameraUri)));
  spdlog::info("calibrate: {} written; the file before is {}, the record {}", a.bench.string(),
               published.backup.string(), published.record.string());
  if (!bench.darkFrame.empty())
    spdlog::warn(
        "calibrate: the dark and flat frames were taken at the exposure before and left the bench: take "
        "them again (lfi calibrate camera {} --dark, then --flat)",
        a.bench.string());
  fmt::print("{}\n", a.bench.string());
  return 0;
}

int runCalibrate(CalibrateArgs a, const GlobalOptions& global) {
  if (a.what == "exposure") return runCalibrateExposure(a, global);
  if (a.dark || a.flat) {
    if (a.what != "camera") lfi::fail(lfi::Errc::Config, "calibrate {}: --dark and --flat are for camera", a.what);
    return runCalibrateFrame(a, global);
  }
  const lfi::BenchFile bench = lfi::readBenchFile(a.bench);
  // Uncertainties at the file's coverage factor, which every <key>_u in it shares.
  a.settings.coverageFactor = a.partSettings.coverageFactor = a.cameraSettings.coverageFactor =
      a.panelSettings.coverageFactor = bench.coverageFactor;
  lfi::BenchFileEdit edit(a.bench);  // the text as it is now: a file edited meanwhile is not replaced
  std::unique_ptr<lfi::sim::ScenePartModel> model;
  if (a.what == "part") {
    if (!bench.cameraOnDisplay)
      lfi::fail(lfi::Errc::Config,
                "{}: [geometry] display_per_pixel_mm and display_at_image_centre_mm (where the camera looks on the "
                "display) are not set: run `lfi calibrate display` first, with the part taken away",
                a.bench.string());
    if (a.model.empty()) lfi::fail(lfi::Errc::Config, "calibrate part: --model names the part's model (a scene file)");
    model = std::make_unique<lfi::sim::ScenePartModel>(a.model);
  }
  std::optional<calib::ChessboardTarget> target;
  if (a.what == "camera") {
    if (a.corners.empty() || !(a.square_mm > 0))
      lfi::fail(lfi::Errc::Config,
                "calibrate camera: --corners COLSxROWS and --square-mm name the chessboard target (inner corners)");
    target = calib::ChessboardTarget::parse(a.corners, a.square_mm);
  }
  const lfi::BenchFile devices = a.part.empty() ? bench : withSimulatedPart(bench, a.part);
  auto display = lfi::openBenchDisplay(devices);
  auto camera = lfi::openBenchCamera(devices, lfi::BenchExposures::OnRequest);
  lfi::NoCapture noCapture;  // (the reference is not needed: the calibrations show their own panels)
  lfi::Controller controller(noCapture, *display, *camera,
                             lfi::controllerOptions(bench, a.frames > 0 ? a.frames : bench.inspectionFrames));
  ProgressBar bar;
  const auto progress = [&](double f) {
    if (!global.quiet) bar(fmt::format("calibrate {}", a.what).c_str(), f);
  };
  const std::string stamp = lfi::utcNow();
  std::string record;
  if (a.what == "display") {
    const lfi::DisplayCalibration c = lfi::calibrateDisplay(controller.probe(), a.settings, progress);
    bar.finish();
    printDisplayCalibration(c);
    lfi::setDisplayCalibration(edit, c, stamp);
    record = lfi::displayCalibrationRecord(c, bench, stamp, lfi::describeCamera(*camera, bench.cameraUri));
  } else if (a.what == "panel") {
    if (!bench.cameraOnDisplay)
      lfi::fail(lfi::Errc::Config,
                "{}: [geometry] display_per_pixel_mm and display_at_image_centre_mm (where the camera looks on the "
                "display) are not set: run `lfi calibrate display` first, with the part taken away",
                a.bench.string());
    const lfi::PanelCalibration c = lfi::calibratePanel(controller.probe(), *bench.cameraOnDisplay,
                                                        bench.cameraUri.text(), a.panelSettings, progress);
    bar.finish();
    printPanelCalibration(c);
    if (c.darkClipped >= 0.01)
      spdlog::warn(
          "calibrate panel: {:.0f} % of the camera's pixels read 0 DN with the panel dark: it clips its "
          "read noise, and the darkest levels read low; raise its black level (BlackLevel) and measure again",
          100 * c.darkClipped);
    lfi::setPanelCalibration(edit, c, stamp);
    record = lfi::panelCalibrationRecord(c, bench, stamp, lfi::describeCamera(*camera, bench.cameraUri));
  } else if (a.what == "camera") {
    const lfi::CameraCalibration c =
        lfi::calibrateCamera(controller.probe(), *target, bench.cameraUri.text(), a.cameraSettings, progress);
    bar.finish();
    printCameraCalibration(c, bench);
    lfi::setCameraCalibration(edit, c, stamp);
    record = lfi::cameraCalibrationRecord(c, bench, stamp, lfi::describeCamera(*camera, bench.cameraUri));
  } else {
    const lfi::PartCalibration c = lfi::calibratePart(controller.probe(), *model, *bench.cameraOnDisplay,
                                                      bench.distance_mm, bench.partCentre_px, a.partSettings, progress);
    bar.finish();
    printPartCalibration(c);
    lfi::setPartCalibration(edit, bench, c, stamp);
    record = lfi::partCalibrationRecord(c, bench, *model, stamp);
  }
  if (a.dryRun) {
    fmt::print("--dry-run: {} would change:\n{}", a.bench.string(), edit.changes());
    return 0;
  }
  const lfi::PublishedCalibration published = lfi::publishCalibration(edit, a.what, stamp, record);
  spdlog::info("calibrate: {} written; the file before is {}, the record {}", a.bench.string(),
               published.backup.string(), published.record.string());
  spdlog::info("calibrate: the reference package depends on these values: take it again (lfi capture {} --force)",
               a.bench.string());
  fmt::print("{}\n", a.bench.string());
  return 0;
}

}  // namespace

Command addCalibrateCommand(CLI::App& app) {
  auto* command = app.add_subcommand(
      "calibrate",
      "Calibrate a bench with its own devices and write the result into its bench file (display: the "
      "display's lens array and the camera's scale, nothing in view; part: Δ, the part's place and the "
      "display's gap, through the intact part; camera: the camera's scale on a chessboard target in the "
      "part's place, or its dark and flat frames; panel: the panel's drive-to-light curve and backlight, nothing in "
      "view; exposure: the camera's exposure, the intact part in view and the display all white)");
  auto a = std::make_shared<CalibrateArgs>();
  command
      ->add_option("what", a->what,
                   "What to calibrate: camera --dark and --flat, display, panel, then part; camera on a "
                   "chessboard where a target is used")
      ->required()
      ->check(CLI::IsMember({"exposure", "display", "part", "camera", "panel"}));
  addBenchArgument(*command, a->bench);
  command->add_flag("--dry-run", a->dryRun, "Measure and print what would change, write nothing");
  command
      ->add_option("--part", a->part,
                   "A simulated bench: the scene under its camera during the calibration (display, panel: one without "
                   "the part, data/scenes/inspection_bench_empty.toml; camera: one with the target, "
                   "data/scenes/inspection_bench_target.toml); a physical bench: take the part away (display), put "
                   "the intact part in place (part) or the target (camera)")
      ->check(CLI::ExistingFile);
  command
      ->add_option("--model", a->model,
                   "part: the part's model, a scene file whose objects other than the display and emitters are "
                   "the part, its origin the part's reference point (data/scenes/inspection_bench.toml)")
      ->check(CLI::ExistingFile);
  auto* dark = command->add_flag(
      "--dark", a->dark,
      "camera: take the dark frame instead, the display dark (cap the lens where room light reaches the camera)");
  command
      ->add_flag("--flat", a->flat,
                 "camera: take the flat frame instead, of a uniform source filling the view (an opal diffuser in the "
                 "part's place, lit by the display; a simulated bench: --part data/scenes/inspection_bench_flat.toml)")
      ->excludes(dark);
  command
      ->add_option("--fraction", a->exposureSettings.fraction,
                   "exposure: where the brightest pixels sit, a fraction of full scale")
      ->check(CLI::Range(0.05, 0.98))
      ->capture_default_str();
  command->add_option("--level-step", a->panelSettings.levelStep, "panel: the drive levels 0, step, 2 step, .., 255")
      ->check(CLI::Range(1, 128))
      ->capture_default_str();
  command->add_option("--corners", a->corners, "camera: the chessboard's inner corners, COLSxROWS (5x5)");
  command->add_option("--square-mm", a->square_mm, "camera: the chessboard's squares' side, mm")
      ->check(CLI::Range(0.001, 1000.0));
  command
      ->add_option("--target-tolerance", a->cameraSettings.targetTolerance,
                   "camera: the board's relative scale uncertainty (standard; a printed board's, a glass one's "
                   "pitch error)")
      ->check(CLI::Range(0.0, 0.1))
      ->capture_default_str();
  command
      ->add_option("--frames", a->frames,
                   fmt::format("Frames averaged per image (default: the bench's [inspection] frames; {} for a "
                               "dark or flat frame)",
                               kFrameCalibrationFrames))
      ->check(CLI::Range(1, 10000));
  command
      ->add_option("--spot-period", a->settings.spotPeriod,
                   "display: light one lens in this many along each lattice axis per spot frame")
      ->check(CLI::Range(2, 16))
      ->capture_default_str();
  return {command, [a](const GlobalOptions& global) { return runCalibrate(*a, global); }};
}

}  // namespace lfi::cli
