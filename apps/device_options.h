#pragma once
// The camera, display and reference light field that `lfi calibrate-distance`
// drives, given on its command line: their options and their opening. (The
// inspection's subcommands take a bench file instead: bench_cli.h.)

#include "lfi/drivers/camera.h"
#include "lfi/drivers/display.h"
#include "lfi/drivers/light_field_capture.h"

#include <CLI/CLI.hpp>

#include <filesystem>
#include <memory>
#include <string>

namespace lfi::cli {

// The devices `lfi calibrate-distance` drives, and how.
struct DeviceOptions {
  std::string camera, display, capture;
  std::filesystem::path lightField;
  int frames = 1;
  double exposure_us = 10'000, gain = 0;
  std::string pixelFormat = "Mono12";
  int settle_ms = 0;
};

void addDeviceOptions(CLI::App& command, DeviceOptions& o);

// The devices opened and the camera configured.
struct OpenDevices {
  std::unique_ptr<lfi::Camera> camera;
  std::unique_ptr<lfi::Display> display;
  std::unique_ptr<lfi::LightFieldCapture> capture;  // a device, or the --light-field file (StoredLightField)
  bool captured = false;                            // a device: the reference is a new capture
};

// Opens through the device registries, which main.cpp fills before any
// subcommand runs.
OpenDevices openDevices(const DeviceOptions& o, const char* command);

}  // namespace lfi::cli
