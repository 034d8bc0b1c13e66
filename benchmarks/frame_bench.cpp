// SPDX-License-Identifier: Apache-2.0
// lfi-frame-bench: the per-frame steps outside the ray tracer and the drivers'
// transfers, each next to a bound measured in the same run.
//
//   step                  what is timed                              bound (same pixels, same run)
//   sensor model          CameraSensorModel::capture of a camera-    one pass over the frame: the float
//                         sized radiance image (the sim: camera's    radiance scaled into 16-bit DN
//                         and the study's shot + read noise), 1      (convertTo), 1 thread; and the exact
//                         thread and all                             sampler on every pixel, for comparison
//   frame correction      FrameCorrection::apply: every image the    cv::subtract of the dark frame (the
//                         controller takes, less the dark frame,     same image in, one pass out)
//                         times the flat frame's gain
//   Mono12 unpack         unpackMono12, both packings (the aravis:   memcpy of the unpacked bytes
//                         backend's Mono12Packed / Mono12p frames)
//   light field EXR       writeLightFieldExr / readLightFieldExr     OpenEXR alone: one FLOAT channel, ZIP,
//   radiance EXR          writeRadianceExr / readRadianceExr         the same frame buffer, no attributes;
//                         (checksums, validation, atomic replace)    the write also with an fsync after it
//
// A ratio is the median of the turns' ratios, printed with their range
// (bench_util.h); a speed is the best run's. Self-checks before the figures:
// the unpacked pixels against a packer written from the formats' byte tables,
// the files' pixels read back bit for bit, the sensor's mean against its exposure,
// the corrected frame against the correction's formula.
//
// Sizes: camera frames 2448 x 2048 (a Sony IMX264's full frame); the light field
// of a 4K panel (292 x 164 spatial x 16^2 angular, 4672 x 2624 pixels, 49 MB).
// --quick: 256 x 256 frames and the study's 40 x 40 x 16^2 light field.
//
// Usage: lfi-frame-bench [--quick] [--turns N] [--dir FOLDER]

#include "lfi/controller/frame_correction.h"
#include "lfi/core/exr_io.h"
#include "lfi/core/light_field.h"
#include "lfi/drivers/pixel_unpack.h"
#include "lfi/sim/devices/camera_sensor_model.h"

#include "bench_util.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfThreading.h>
#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>
#include <CLI/CLI.hpp>

#include <opencv2/core.hpp>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <functional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace fs = std::filesystem;
using namespace lfi;
using lfi::bench::bestOf;
using lfi::bench::ratiosByTurn;
using lfi::bench::secondsInTurns;
using lfi::bench::spreadOf;

namespace {

void keep(const void* p) {
  asm volatile("" : : "r"(p) : "memory");
}

void printRatio(const char* label, const lfi::bench::TurnSeconds& s, size_t a, size_t b) {
  const auto r = spreadOf(ratiosByTurn(s, a, b));
  fmt::print("  ratio {:<34} {:6.2f}  (turns {:.2f}-{:.2f})\n", label, r.median, r.low, r.high);
}

// ---- sensor model -----------------------------------------------------------

void sensorModel(int width, int height, int turns) {
  cv::Mat radiance(height, width, CV_32FC1);
  cv::RNG(7).fill(radiance, cv::RNG::UNIFORM, 0.0, 1.0);
  sim::CameraSensorModel model;
  model.exposeFor(1.0);  // radiance 1 at 70 % of the well: means 0..7350 e-
  const int threads = static_cast<int>(std::thread::hardware_concurrency());

  // Self-check: the mean digital number is the exposure's (uniform radiance: half of 70 % of full scale).
  const cv::Mat check = model.capture(radiance, 1, threads);
  const double expected = 0.35 * model.maxDigitalNumber(), mean = cv::mean(check)[0];
  if (std::abs(mean - expected) > 0.01 * expected)
    throw std::runtime_error(fmt::format("self-check: sensor mean {:.1f} DN, expected {:.1f}", mean, expected));

  const long pixels = static_cast<long>(width) * height;
  sim::CameraSensorModel exact = model;
  exact.readNoise_e = 1.9;  // below sensor_noise.h's kTransformedMinReadNoise_e: every pixel drawn exactly
  cv::Mat out;
  const auto s = secondsInTurns(
      turns, {[&] { out = model.capture(radiance, 2, 1); }, [&] { out = model.capture(radiance, 3, threads); },
              [&] { out = exact.capture(radiance, 4, 1); },
              [&] {  // the bound: one pass over the frame, radiance in, DN out
                radiance.convertTo(out, CV_16U, 0.35 * model.maxDigitalNumber());
                keep(out.data);
              }});
  fmt::print("sensor model, {} x {} radiance -> 12-bit DN (shot + read noise)\n", width, height);
  fmt::print("  capture, 1 thread                   {:8.2f} ms  {:6.1f} M pixels/s\n", 1e3 * bestOf(s, 0),
             pixels / bestOf(s, 0) / 1e6);
  fmt::print("  capture, {} threads                  {:8.2f} ms  {:6.1f} M pixels/s\n", threads, 1e3 * bestOf(s, 1),
             pixels / bestOf(s, 1) / 1e6);
  fmt::print("  exact draws, 1 thread               {:8.2f} ms  (read noise 1.9 e-: no transformed draw)\n",
             1e3 * bestOf(s, 2));
  fmt::print("  bound: one pass over the frame      {:8.2f} ms  (float radiance -> 16-bit DN, 1 thread)\n",
             1e3 * bestOf(s, 3));
  printRatio("capture (1 thread) / one pass", s, 0, 3);
  printRatio("capture (all threads) / one pass", s, 1, 3);
  printRatio("exact draws / capture (1 thread)", s, 2, 0);
}

// ---- frame correction -------------------------------------------------------

void frameCorrection(int width, int height, int turns) {
  CalibrationFrame dark, flat;
  dark.kind = CalibrationFrameKind::Dark;
  flat.kind = CalibrationFrameKind::Flat;
  dark.settings.pixelFormat = flat.settings.pixelFormat = PixelFormat::Mono12;
  dark.image = cv::Mat(height, width, CV_32FC1);
  flat.image = cv::Mat(height, width, CV_32FC1);
  cv::RNG(17).fill(dark.image, cv::RNG::UNIFORM, 60.0, 70.0);
  cv::RNG(19).fill(flat.image, cv::RNG::UNIFORM, 1800.0, 2200.0);
  const FrameCorrection correction(dark, flat);
  cv::Mat frame(height, width, CV_32FC1);
  cv::RNG(23).fill(frame, cv::RNG::UNIFORM, 0.0, 4000.0);
  // Self-check: one pixel against the formula.
  cv::Mat check = frame.clone();
  correction.apply(check);
  const double expected = (frame.at<float>(5, 7) - dark.image.at<float>(5, 7)) * correction.gain().at<float>(5, 7);
  if (std::abs(check.at<float>(5, 7) - expected) > 1e-3 * std::abs(expected) + 1e-3)
    throw std::runtime_error(fmt::format("self-check: corrected {} DN, expected {}", check.at<float>(5, 7), expected));

  cv::Mat image = frame.clone(), out(frame.size(), CV_32FC1);
  const auto s = secondsInTurns(turns, {[&] {
                                          frame.copyTo(image);  // (the bound copies too: the same work beside)
                                          correction.apply(image);
                                          keep(image.data);
                                        },
                                        [&] {
                                          frame.copyTo(image);
                                          cv::subtract(image, dark.image, out);
                                          keep(out.data);
                                        }});
  fmt::print("frame correction, {} x {} float frame (dark and flat)\n", width, height);
  fmt::print("  copy + FrameCorrection::apply       {:8.2f} ms\n", 1e3 * bestOf(s, 0));
  fmt::print("  bound: copy + cv::subtract of dark  {:8.2f} ms\n", 1e3 * bestOf(s, 1));
  printRatio("correction / subtract", s, 0, 1);
}

// ---- Mono12 unpack ----------------------------------------------------------

// The two layouts of pixel_unpack.h, written from their byte tables.
std::vector<std::uint8_t> packMono12(const cv::Mat& pixels, Mono12Packing packing) {
  std::vector<std::uint8_t> out(mono12PackedSize(pixels.cols, pixels.rows));
  const auto* p = pixels.ptr<std::uint16_t>(0);
  const size_t n = pixels.total();
  for (size_t i = 0; i < n; i += 2) {
    const unsigned p0 = p[i], p1 = i + 1 < n ? p[i + 1] : 0;
    std::uint8_t* t = out.data() + i / 2 * 3;
    if (packing == Mono12Packing::GigEVisionPacked) {
      t[0] = static_cast<std::uint8_t>(p0 >> 4);
      t[1] = static_cast<std::uint8_t>(((p1 & 0xF) << 4) | (p0 & 0xF));
    } else {
      t[0] = static_cast<std::uint8_t>(p0 & 0xFF);
      t[1] = static_cast<std::uint8_t>(((p1 & 0xF) << 4) | (p0 >> 8));
    }
    if (i + 1 < n) t[2] = static_cast<std::uint8_t>(p1 >> 4);
  }
  return out;
}

void mono12(int width, int height, int turns) {
  cv::Mat pixels(height, width, CV_16UC1);
  cv::RNG(9).fill(pixels, cv::RNG::UNIFORM, 0, 4096);
  const auto gev = packMono12(pixels, Mono12Packing::GigEVisionPacked);
  const auto pfnc = packMono12(pixels, Mono12Packing::Pfnc);
  cv::Mat a, b;
  unpackMono12(gev.data(), gev.size(), width, height, Mono12Packing::GigEVisionPacked, a);
  unpackMono12(pfnc.data(), pfnc.size(), width, height, Mono12Packing::Pfnc, b);
  if (cv::norm(a, pixels, cv::NORM_INF) != 0 || cv::norm(b, pixels, cv::NORM_INF) != 0)
    throw std::runtime_error("self-check: an unpacked Mono12 frame differs from the pixels packed");

  const size_t bytes = pixels.total() * pixels.elemSize();
  cv::Mat copy(pixels.size(), pixels.type(), cv::Scalar(1));  // touched: no page faults inside the timing
  const auto s =
      secondsInTurns(turns, {[&] {
                               unpackMono12(gev.data(), gev.size(), width, height, Mono12Packing::GigEVisionPacked, a);
                               keep(a.data);
                             },
                             [&] {
                               unpackMono12(pfnc.data(), pfnc.size(), width, height, Mono12Packing::Pfnc, b);
                               keep(b.data);
                             },
                             [&] {
                               std::memcpy(copy.data, pixels.data, bytes);
                               keep(copy.data);
                             }});
  fmt::print("Mono12 unpack, {} x {} ({:.1f} MB packed -> {:.1f} MB)\n", width, height, gev.size() / 1e6, bytes / 1e6);
  fmt::print("  Mono12Packed (GigE Vision)          {:8.3f} ms  {:6.0f} M pixels/s\n", 1e3 * bestOf(s, 0),
             pixels.total() / bestOf(s, 0) / 1e6);
  fmt::print("  Mono12p (PFNC)                      {:8.3f} ms  {:6.0f} M pixels/s\n", 1e3 * bestOf(s, 1),
             pixels.total() / bestOf(s, 1) / 1e6);
  fmt::print("  bound: memcpy of the unpacked bytes {:8.3f} ms  {:6.2f} GB/s\n", 1e3 * bestOf(s, 2),
             bytes / bestOf(s, 2) / 1e9);
  printRatio("Mono12Packed / memcpy", s, 0, 2);
  printRatio("Mono12p / memcpy", s, 1, 2);
}

// ---- EXR files ---------------------------------------------------------------

// OpenEXR alone: the pixels as lfi writes them (one FLOAT channel "Y", ZIP), no attributes.
void writePlainExr(const fs::path& path, const cv::Mat& pixels, bool sync) {
  Imf::Header header(pixels.cols, pixels.rows);
  header.compression() = Imf::ZIP_COMPRESSION;
  header.channels().insert("Y", Imf::Channel(Imf::FLOAT));
  {
    Imf::OutputFile file(path.c_str(), header);
    Imf::FrameBuffer frame;
    frame.insert("Y", Imf::Slice(Imf::FLOAT, const_cast<char*>(pixels.ptr<char>()), sizeof(float), pixels.step));
    file.setFrameBuffer(frame);
    file.writePixels(pixels.rows);
  }
  if (sync) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    const int rc = fd < 0 ? -1 : ::fsync(fd), err = errno;
    if (fd >= 0) ::close(fd);
    if (rc != 0) throw std::runtime_error(fmt::format("fsync '{}': {}", path.string(), std::strerror(err)));
  }
}

cv::Mat readPlainExr(const fs::path& path) {
  Imf::InputFile file(path.c_str());
  const Imath::Box2i window = file.header().dataWindow();
  cv::Mat pixels(window.max.y - window.min.y + 1, window.max.x - window.min.x + 1, CV_32FC1);
  Imf::FrameBuffer frame;
  char* base =
      pixels.ptr<char>() - (static_cast<std::ptrdiff_t>(window.min.y) * static_cast<std::ptrdiff_t>(pixels.step) +
                            window.min.x * static_cast<std::ptrdiff_t>(sizeof(float)));
  frame.insert("Y", Imf::Slice(Imf::FLOAT, base, sizeof(float), pixels.step));
  file.setFrameBuffer(frame);
  file.readPixels(window.min.y, window.max.y);
  return pixels;
}

bool sameBits(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return false;
  for (int r = 0; r < a.rows; ++r)
    if (std::memcmp(a.ptr(r), b.ptr(r), a.cols * a.elemSize()) != 0) return false;
  return true;
}

void exrFiles(const char* what, const cv::Mat& pixels, const std::function<void(const fs::path&)>& writeOurs,
              const std::function<cv::Mat(const fs::path&)>& readOurs, const fs::path& dir, int turns) {
  const fs::path ours = dir / "lfi.exr", plain = dir / "plain.exr";
  writeOurs(ours);
  writePlainExr(plain, pixels, false);
  if (!sameBits(readOurs(ours), pixels) || !sameBits(readPlainExr(plain), pixels))
    throw std::runtime_error(fmt::format("self-check: the {} file's pixels differ from those written", what));
  cv::Mat in;
  const auto s = secondsInTurns(turns, {[&] { writeOurs(ours); }, [&] { writePlainExr(plain, pixels, false); },
                                        [&] { writePlainExr(plain, pixels, true); },
                                        [&] {
                                          in = readOurs(ours);
                                          keep(in.data);
                                        },
                                        [&] {
                                          in = readPlainExr(plain);
                                          keep(in.data);
                                        }});
  const double mb = pixels.total() * pixels.elemSize() / 1e6;
  fmt::print("{} EXR, {} x {} float ({:.1f} MB of pixels, {:.1f} MB file), OpenEXR's pool {} threads, folder {}\n",
             what, pixels.cols, pixels.rows, mb, fs::file_size(ours) / 1e6, Imf::globalThreadCount(), dir.string());
  fmt::print("  write (lfi)                         {:8.2f} ms  {:6.0f} MB/s\n", 1e3 * bestOf(s, 0), mb / bestOf(s, 0));
  fmt::print("  bound: OpenEXR alone                {:8.2f} ms  {:6.0f} MB/s\n", 1e3 * bestOf(s, 1), mb / bestOf(s, 1));
  fmt::print("  bound: OpenEXR + fsync              {:8.2f} ms  {:6.0f} MB/s\n", 1e3 * bestOf(s, 2), mb / bestOf(s, 2));
  fmt::print("  read (lfi)                          {:8.2f} ms  {:6.0f} MB/s\n", 1e3 * bestOf(s, 3), mb / bestOf(s, 3));
  fmt::print("  bound: OpenEXR alone                {:8.2f} ms  {:6.0f} MB/s\n", 1e3 * bestOf(s, 4), mb / bestOf(s, 4));
  printRatio("write / OpenEXR alone", s, 0, 1);
  printRatio("write / OpenEXR + fsync", s, 0, 2);
  printRatio("read / OpenEXR alone", s, 3, 4);
}

int run(int argc, char** argv) {
  bool quick = false;
  int turns = 7;
  std::string parent = fs::temp_directory_path().string();
  CLI::App app(
      "lfi-frame-bench: sensor model, frame correction, Mono12 unpacking and EXR files against bounds measured in "
      "the same run");
  app.add_flag("--quick", quick, "Small frames and the study's light field, 2 turns (a smoke run)");
  app.add_option("--turns", turns, "Turns of each step and its bound; a ratio is their median")
      ->check(CLI::Range(1, 1000));
  app.add_option("--dir", parent, "Folder for the EXR files (a temporary folder is made inside it)")
      ->check(CLI::ExistingDirectory);
  CLI11_PARSE(app, argc, argv);
  if (quick && app.count("--turns") == 0) turns = 2;

  const int width = quick ? 256 : 2448, height = quick ? 256 : 2048;
  fmt::print("lfi-frame-bench: {} turns, {} hardware threads\n", turns, std::thread::hardware_concurrency());
  sensorModel(width, height, turns);
  frameCorrection(width, height, turns);
  mono12(width, height, turns);

  const lfi::bench::TemporaryFolder dir(parent, "lfi-frame-bench");
  const LightFieldGeometry g =
      quick ? LightFieldGeometry{40, 40, 16, 0.05, 30} : LightFieldGeometry{292, 164, 16, 1.0 / 16, 30};
  LightField lightField(g);
  cv::RNG(11).fill(lightField.lensletImage(), cv::RNG::UNIFORM, 0.0, 1.0);
  exrFiles(
      "light field", lightField.lensletImage(),
      [&](const fs::path& p) { writeLightFieldExr(p, lightField, Overwrite::Allow); },
      [](const fs::path& p) { return readLightFieldExr(p).lensletImage(); }, dir.path(), turns);

  cv::Mat radiance(height, width, CV_32FC1);
  cv::RNG(13).fill(radiance, cv::RNG::UNIFORM, 0.0, 4.0);
  exrFiles(
      "radiance", radiance,
      [&](const fs::path& p) { writeRadianceExr(p, radiance, {.objectPixel_mm = 0.0568}, Overwrite::Allow); },
      [](const fs::path& p) { return readRadianceExr(p); }, dir.path(), turns);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return lfi::bench::runGuarded("lfi-frame-bench", [&] { return run(argc, argv); });
}
