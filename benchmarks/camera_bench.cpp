// SPDX-License-Identifier: Apache-2.0
// lfi-camera-bench: the simulated GigE Vision camera (`lfi serve-camera` on
// loopback) streamed through our Aravis backend, next to a plain Aravis client
// (arv_camera / arv_stream C API, no copy) streaming the same device in the
// same run. Prints sustained frame rate, MB/s, lost frames, their ratio, and
// the per-frame cost of each grab path when a frame is already waiting.
//
//   lfi-camera-bench [--frames N] [--rate HZ] [--size PX] [--format Mono8|Mono16] [--rounds N]

#include "lfi/drivers/aravis/aravis_camera.h"
#include "lfi/drivers/builtin_backends.h"
#include "lfi/drivers/camera_registry.h"

#include "bench_util.h"
#include "gige_device_process.h"

#include <arv.h>
#include <fmt/format.h>
#include <signal.h>
#include <unistd.h>
#include <CLI/CLI.hpp>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;
using lfi::testing_support::missingBlockIds;
namespace fs = std::filesystem;

double seconds(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double>(b - a).count();
}

struct Result {
  double fps = 0;
  double megabytesPerSecond = 0;
  std::uint64_t lost = 0;   // id gaps (dropped frames, underruns and timeouts among them) + incomplete frames
  double readyGrab_us = 0;  // mean cost of one grab when the frame is already waiting
};

constexpr int kBuffers = 16;

void printResult(const char* name, const Result& r) {
  fmt::print("  {:<28} {:8.1f} frames/s {:8.1f} MB/s  lost {:3}  grab of a waiting frame {:7.1f} us\n", name, r.fps,
             r.megabytesPerSecond, r.lost, r.readyGrab_us);
}

Result benchOurs(const std::string& id, int frames, double rate, int size, lfi::PixelFormat format) {
  auto camera = lfi::openCamera(lfi::DeviceUri{.scheme = "aravis", .path = id});
  lfi::CameraSettings s;
  s.exposure_us = 2000;
  s.pixelFormat = format;
  s.roiWidth_px = size;
  s.roiHeight_px = size;
  s.frameRate_hz = rate;
  camera->configure(s);
  camera->start(kBuffers);
  lfi::Frame frame;
  camera->grabInto(frame, std::chrono::seconds(5));  // the first frame: set-up, not timed
  const std::uint64_t firstId = frame.frameId;
  const auto t0 = Clock::now();
  std::uint64_t bytes = 0, lost = 0, previous = firstId;
  for (int i = 0; i < frames; ++i) {
    camera->grabInto(frame, std::chrono::seconds(2));
    // Lost: the ids skipped (dropped frames, underruns among them, and timeouts) and the incomplete ones.
    if (frame.status == lfi::FrameStatus::Timeout) continue;  // (the next id's gap counts it)
    lost += missingBlockIds(previous, frame.frameId) + (frame.status == lfi::FrameStatus::Complete ? 0 : 1);
    previous = frame.frameId;
    if (frame.status != lfi::FrameStatus::Complete) continue;
    bytes += frame.image.total() * frame.image.elemSize();
  }
  const auto t1 = Clock::now();
  Result r;
  r.fps = frames / seconds(t0, t1);
  r.megabytesPerSecond = static_cast<double>(bytes) / 1e6 / seconds(t0, t1);
  // Let the buffers fill, then time grabs that find their frame waiting.
  std::this_thread::sleep_for(std::chrono::duration<double>((kBuffers / 2 + 1) / rate));
  const auto g0 = Clock::now();
  for (int i = 0; i < kBuffers / 2; ++i) camera->grabInto(frame, std::chrono::seconds(2));
  r.readyGrab_us = seconds(g0, Clock::now()) * 1e6 / (kBuffers / 2);
  r.lost = lost;
  camera->stop();
  return r;
}

void check(GError* error, const char* call) {
  if (error == nullptr) return;
  const std::string message = error->message;
  g_error_free(error);
  throw std::runtime_error(fmt::format("plain Aravis client: {} failed: {}", call, message));
}

// The plain client: what an application using Aravis directly would write. It
// opens the device through 127.0.0.1, as our backend does for a device at one of
// the host's own addresses: Aravis's discovery may find a device on 127.0.0.1
// through eth0 too, and then (as root) its packet socket, bound to eth0, never
// sees the stream, which goes through lo (drivers/src/aravis/).
// (Owned GObjects, released however the client ends, with its acquisition stopped.)
struct Unref {
  void operator()(gpointer object) const { g_object_unref(object); }
};
template <typename T>
using Owned = std::unique_ptr<T, Unref>;

Result benchPlain(int frames, double rate, int size, lfi::PixelFormat format) {
  GError* error = nullptr;
  GInetAddress* loopback = g_inet_address_new_loopback(G_SOCKET_FAMILY_IPV4);
  ArvDevice* device = arv_gv_device_new(loopback, loopback, &error);
  g_object_unref(loopback);
  check(error, "arv_gv_device_new (127.0.0.1)");
  const Owned<ArvCamera> owner(arv_camera_new_with_device(device, &error));
  ArvCamera* camera = owner.get();
  g_object_unref(device);  // (the camera holds its own reference)
  check(error, "arv_camera_new_with_device");
  arv_camera_set_region(camera, 0, 0, size, size, &error);
  check(error, "arv_camera_set_region");
  arv_camera_set_pixel_format(
      camera, format == lfi::PixelFormat::Mono8 ? ARV_PIXEL_FORMAT_MONO_8 : ARV_PIXEL_FORMAT_MONO_16, &error);
  check(error, "arv_camera_set_pixel_format");
  arv_camera_set_exposure_time(camera, 2000, &error);
  check(error, "arv_camera_set_exposure_time");
  arv_camera_set_frame_rate(camera, rate, &error);
  check(error, "arv_camera_set_frame_rate");
  arv_camera_gv_auto_packet_size(camera, &error);
  check(error, "arv_camera_gv_auto_packet_size");
  const Owned<ArvStream> streamOwner(arv_camera_create_stream(camera, nullptr, nullptr, &error));
  ArvStream* stream = streamOwner.get();
  check(error, "arv_camera_create_stream");
  const unsigned payload = arv_camera_get_payload(camera, &error);
  check(error, "arv_camera_get_payload");
  for (int i = 0; i < kBuffers; ++i) arv_stream_push_buffer(stream, arv_buffer_new_allocate(payload));
  arv_camera_start_acquisition(camera, &error);
  check(error, "arv_camera_start_acquisition");
  struct StopAcquisition {
    ArvCamera* camera;
    ~StopAcquisition() { arv_camera_stop_acquisition(camera, nullptr); }
  } const stop{camera};
  ArvBuffer* buffer = arv_stream_timeout_pop_buffer(stream, 5'000'000);
  if (buffer == nullptr) throw std::runtime_error("plain Aravis client: no first frame in 5 s");
  std::uint64_t previous = arv_buffer_get_frame_id(buffer);
  arv_stream_push_buffer(stream, buffer);
  const auto t0 = Clock::now();
  std::uint64_t bytes = 0, lost = 0;
  for (int i = 0; i < frames; ++i) {
    buffer = arv_stream_timeout_pop_buffer(stream, 2'000'000);
    if (buffer == nullptr) continue;  // (the next id's gap counts it)
    const std::uint64_t frameId = arv_buffer_get_frame_id(buffer);
    const bool complete = arv_buffer_get_status(buffer) == ARV_BUFFER_STATUS_SUCCESS;
    lost += missingBlockIds(previous, frameId) + (complete ? 0 : 1);  // as in benchOurs
    previous = frameId;
    if (complete) {
      size_t size_bytes = 0;
      arv_buffer_get_image_data(buffer, &size_bytes);
      bytes += size_bytes;
    }
    arv_stream_push_buffer(stream, buffer);
  }
  const auto t1 = Clock::now();
  Result r;
  r.fps = frames / seconds(t0, t1);
  r.megabytesPerSecond = static_cast<double>(bytes) / 1e6 / seconds(t0, t1);
  std::this_thread::sleep_for(std::chrono::duration<double>((kBuffers / 2 + 1) / rate));
  const auto g0 = Clock::now();
  for (int i = 0; i < kBuffers / 2; ++i) {
    buffer = arv_stream_timeout_pop_buffer(stream, 2'000'000);
    if (buffer != nullptr) arv_stream_push_buffer(stream, buffer);
  }
  r.readyGrab_us = seconds(g0, Clock::now()) * 1e6 / (kBuffers / 2);
  r.lost = lost;
  return r;
}

int run(int frames, double rate, int size, lfi::PixelFormat format, int rounds) {
  // The reference lens over its back light, size x size pixels over the same 60 mm field, 4 samples per pixel.
  struct Folder {  // (removed however the bench ends)
    fs::path path;
    ~Folder() {
      std::error_code ignored;
      fs::remove_all(path, ignored);
    }
  } const folder{fs::temp_directory_path() / fmt::format("lfi-camera-bench-{}", ::getpid())};
  const fs::path& dir = folder.path;
  fs::create_directories(dir);
  const fs::path scene = dir / "bench.toml";
  std::ifstream reference(fs::path(LFI_SOURCE_DIR) / "data/scenes/reference.toml");
  std::string text((std::istreambuf_iterator<char>(reference)), std::istreambuf_iterator<char>());
  auto replace = [&text](const std::string& from, const std::string& to) {
    const auto at = text.find(from);
    if (at == std::string::npos) throw std::runtime_error("reference scene changed: no '" + from + "'");
    text.replace(at, from.size(), to);
  };
  replace("samples_per_pixel = 16", "samples_per_pixel = 4");
  replace("pixel_pitch_mm = 0.1171875", fmt::format("pixel_pitch_mm = {}", 60.0 / size));
  replace("width = 512", fmt::format("width = {}", size));
  replace("height = 512", fmt::format("height = {}", size));
  std::ofstream(scene) << text;

  // One GigE Vision device on 127.0.0.1 at a time (the loopback tests hold the same lock).
  const lfi::testing_support::LoopbackGigeLock lock;
  const std::string serial = fmt::format("BENCH{}", ::getpid() % 100000);
  {
    lfi::testing_support::GigeDeviceProcess server(
        {LFI_EXECUTABLE, "-q", "serve-camera", scene.string(), "--serial", serial}, std::chrono::seconds(60), false);
    lfi::registerDriverBackends();
    const std::string id = "lfi-SimCamera-" + serial;
    const double megabytes = size * size * (format == lfi::PixelFormat::Mono8 ? 1.0 : 2.0) / 1e6;
    fmt::print("lfi-camera-bench: {} frames of {} x {} {} ({:.3f} MB) at {} Hz from '{}' on 127.0.0.1\n", frames, size,
               size, lfi::toString(format), megabytes, rate, id);
    lfi::listAravisDevices();  // discovery once, so both clients open a known device
    // Rounds alternating between the clients, so that a load change on the machine hits both; a ratio is
    // the median of the rounds' (each round's two ends ran one after the other), speeds the best round's.
    Result plain, ours;
    std::uint64_t lostOurs = 0, lostPlain = 0;  // over all rounds
    std::vector<double> fpsRatio, grabExtra_us;
    for (int round = 0; round < rounds; ++round) {
      Result p, o;  // the clients in alternating order
      if (round % 2 == 0) p = benchPlain(frames, rate, size, format);
      o = benchOurs(id, frames, rate, size, format);
      if (round % 2 == 1) p = benchPlain(frames, rate, size, format);
      fmt::print("round {}\n", round + 1);
      printResult("plain Aravis client", p);
      printResult("lfi Aravis backend", o);
      if (!(p.megabytesPerSecond > 0) || !(o.megabytesPerSecond > 0))
        throw std::runtime_error(fmt::format("round {}: a client got no complete frame", round + 1));
      if (p.fps > plain.fps) plain = p;
      if (o.fps > ours.fps) ours = o;
      lostPlain += p.lost, lostOurs += o.lost;
      fpsRatio.push_back(o.fps / p.fps);
      // Meaningful only when frames were waiting, i.e. the device kept up with the rate.
      if (o.readyGrab_us < 1000 && p.readyGrab_us < 1000) grabExtra_us.push_back(o.readyGrab_us - p.readyGrab_us);
    }
    const auto fps = lfi::bench::spreadOf(fpsRatio);
    fmt::print(
        "frames/s ours / plain: {:.3f} (median of {} rounds; {:.3f}-{:.3f}); lost frames over all rounds {} "
        "(ours), {} (plain) (target >= 0.95, 0 lost; both clients stream at the device's rate, so this "
        "shows frames lost or late, not the grab's cost)\n",
        fps.median, rounds, fps.low, fps.high, lostOurs, lostPlain);
    if (!grabExtra_us.empty()) {
      // The overhead's floor: the copy of a frame's bytes into the caller's image (measured here).
      const size_t bytes = static_cast<size_t>(megabytes * 1e6);
      std::vector<unsigned char> from(bytes, 1), to(bytes, 2);
      const double copy_us = 1e6 * lfi::bench::bestSeconds(200, [&] {
                               std::memcpy(to.data(), from.data(), bytes);
                               asm volatile("" : : "r"(to.data()) : "memory");
                             });
      const auto extra = lfi::bench::spreadOf(grabExtra_us);
      fmt::print(
          "per-frame overhead of our grab path over a bare pop/push (copy into the cv::Mat included): "
          "{:.1f} us (median of {} rounds; {:.1f}-{:.1f}); memcpy of a frame: {:.1f} us\n",
          extra.median, grabExtra_us.size(), extra.low, extra.high, copy_us);
    } else {
      fmt::print("per-frame overhead: not measured (the device did not keep up with {} Hz, no frames were waiting)\n",
                 rate);
    }
    server.signal(SIGTERM);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  int frames = 500, size = 512, rounds = 3;
  double rate = 100;
  std::string formatName = "Mono8";
  CLI::App app("lfi-camera-bench: the simulated GigE Vision camera through our Aravis backend and a plain client");
  app.add_option("--frames", frames, "Frames per client and round")->check(CLI::Range(1, 1000000));
  app.add_option("--rate", rate, "Frame rate asked of the device, Hz")->check(CLI::Range(0.1, 10000.0));
  app.add_option("--size", size, "Sensor width and height, px")->check(CLI::Range(8, 4096));
  app.add_option("--format", formatName, "Pixel format")->check(CLI::IsMember({"Mono8", "Mono16"}));
  app.add_option("--rounds", rounds, "Rounds, alternating the clients; a ratio is their median")
      ->check(CLI::Range(1, 1000));
  CLI11_PARSE(app, argc, argv);
  const lfi::PixelFormat format = formatName == "Mono16" ? lfi::PixelFormat::Mono16 : lfi::PixelFormat::Mono8;
  return lfi::bench::runGuarded("lfi-camera-bench", [&] { return run(frames, rate, size, format, rounds); });
}
