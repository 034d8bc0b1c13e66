// SPDX-License-Identifier: Apache-2.0
// lfi-output-bench: how long a part's verdict takes to reach the line over
// MQTT ([output.mqtt], mqtt_output.h), against the verdict's own time in the
// same run. A run on the simulated bench publishes to a mosquitto broker
// started here on loopback; a subscriber in this process notes when each
// record arrives.
//
//   measured   from the part's last frame leaving the camera (grabInto
//              returning) to its record arriving at the subscriber through
//              the broker: the verdict, the part's images and record written
//              and flushed to the disk (records.jsonl, fdatasync), the
//              publish, the broker's hop
//   bound      the verdict's own time in the same part (its record's
//              analysis_ms: the image in hand to the verdict)
//   ratio      measured / bound per part: median and 95th percentile
//
// Usage: lfi-output-bench [--parts N] [--save-images all|failed|none] [--quick]
//   --quick    5 parts (a smoke run)

#include "lfi/controller/bench_file.h"
#include "lfi/controller/run.h"
#include "lfi/drivers/camera_registry.h"
#include "lfi/sim/devices/sim_camera.h"

#include "bench_util.h"
#include "forwarding_camera.h"
#include "mosquitto_broker.h"
#include "quick_run_bench.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <atomic>
#include <chrono>
#include <map>
#include <mutex>

namespace fs = std::filesystem;
using namespace lfi;
using Clock = std::chrono::steady_clock;

namespace {

std::atomic<Clock::rep> lastFrame{0};  // when the camera last handed a frame over

// The sim: camera, noting when each frame leaves it.
class StampedCamera final : public testing_support::ForwardingCamera {
 public:
  using ForwardingCamera::ForwardingCamera;
  void grabInto(Frame& frame, std::chrono::milliseconds timeout) override {
    inner().grabInto(frame, timeout);
    lastFrame = Clock::now().time_since_epoch().count();
  }
};

}  // namespace

int main(int argc, char** argv) try {
  CLI::App app{"lfi-output-bench: a part's frame to its record on the MQTT broker, against the verdict's time"};
  long parts = 40;
  std::string saveImages = "failed";
  bool quick = false;
  app.add_option("--parts", parts, "Parts in the run")->check(CLI::Range(2L, 100000L));
  app.add_option("--save-images", saveImages, "The bench's [output] save_images")
      ->check(CLI::IsMember({"all", "failed", "none"}));
  app.add_flag("--quick", quick, "5 parts (a smoke run)");
  CLI11_PARSE(app, argc, argv);
  if (quick) parts = 5;
  spdlog::set_level(spdlog::level::warn);
  if (testing_support::mosquittoProgram().empty()) throw std::runtime_error("no mosquitto (Debian: mosquitto)");

  sim::registerSimBackends();
  backendRegistry<Camera>().addOnce(CameraBackend{
      .scheme = "stamped",
      .description = "stamped:<scene-file>  the sim: camera, noting when each frame leaves it",
      .factory = [](const DeviceUri& uri) -> std::unique_ptr<Camera> {
        return std::make_unique<StampedCamera>(openCamera(DeviceUri{.scheme = "sim", .path = uri.path}));
      },
  });
  testing_support::TestFolder folder("lfi-output-bench");
  testing_support::MosquittoBroker broker(folder.path() / "broker");
  testing_support::MqttListener listener(broker.port(), "bench/record", "lfi-output-bench");

  std::string text = testing_support::quickRunBenchText("stamped");
  testing_support::replaceOnce(text, "save_images = \"failed\"", "save_images = \"" + saveImages + "\"");
  const ReferencePackage package = testing_support::quickRunReference(folder, text);
  const BenchFile bench = readBenchFile(folder.write(
      "bench-mqtt.toml", text + "\n[output.mqtt]\nbroker = \"" + broker.url() + "\"\ntopic = \"bench\"\n"));

  std::mutex mutex;
  std::map<std::uint64_t, Clock::rep> frameOf;  // part → its last frame's time
  RunOptions options;
  options.folder = folder.path() / "run";
  options.parts = parts;
  // (onRecord runs after the record is published: the part's last frame is the camera's last)
  options.onRecord = [&](const InspectionRecord& r) {
    std::lock_guard lock(mutex);
    frameOf[r.part] = lastFrame.load();
  };
  const RunResult result = runParts(bench, bench, package, options);
  if (!result.outputProblems.empty()) throw std::runtime_error(result.outputProblems.front());
  if (!listener.waitFor([&](const auto& m) { return m.size() >= static_cast<std::size_t>(parts); },
                        std::chrono::seconds(30)))
    throw std::runtime_error("the subscriber did not receive every record");

  // Each message against its part's last frame, both on this process's steady clock.
  std::vector<double> latency_ms, verdict_ms, ratio;
  for (const testing_support::MqttMessage& m : listener.messages()) {
    const auto record = nlohmann::json::parse(m.payload);
    const std::uint64_t part = record["part"];
    std::lock_guard lock(mutex);
    const double ms =
        std::chrono::duration<double, std::milli>(m.arrival - Clock::time_point(Clock::duration(frameOf.at(part))))
            .count();
    latency_ms.push_back(ms);
    verdict_ms.push_back(record["analysis_ms"].get<double>());
    ratio.push_back(ms / verdict_ms.back());
  }
  fmt::print("lfi-output-bench: {} parts on the simulated bench, save_images = {}, QoS 1, mosquitto on loopback\n",
             parts, saveImages);
  fmt::print("  frame → record on the broker   median {:8.2f} ms   95th percentile {:8.2f} ms\n",
             bench::percentile(latency_ms, 0.5), bench::percentile(latency_ms, 0.95));
  fmt::print("  the verdict's own time (bound) median {:8.2f} ms   95th percentile {:8.2f} ms\n",
             bench::percentile(verdict_ms, 0.5), bench::percentile(verdict_ms, 0.95));
  fmt::print("  ratio                          median {:8.2f}      95th percentile {:8.2f}\n",
             bench::percentile(ratio, 0.5), bench::percentile(ratio, 0.95));
  return 0;
} catch (const std::exception& e) {
  fmt::print(stderr, "lfi-output-bench: {}\n", e.what());
  return 1;
}
