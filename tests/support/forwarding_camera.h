// SPDX-License-Identifier: Apache-2.0
#pragma once
// A camera that hands every call to another (a sim: camera, say), for tests
// and benchmarks that change one call: a camera that drops out at a grab, or
// one that notes when its frames leave it.

#include "lfi/drivers/camera.h"

#include <memory>
#include <string>

namespace lfi::testing_support {

class ForwardingCamera : public Camera {
 public:
  explicit ForwardingCamera(std::unique_ptr<Camera> inner) : inner_(std::move(inner)) {}
  State state() const override { return inner_->state(); }
  void open() override { inner_->open(); }
  void close() noexcept override { inner_->close(); }
  CameraInfo info() const override { return inner_->info(); }
  void configure(const CameraSettings& s) override { inner_->configure(s); }
  CameraSettings settings() const override { return inner_->settings(); }
  void start(int buffers) override { inner_->start(buffers); }
  void stop() override { inner_->stop(); }
  void softwareTrigger() override { inner_->softwareTrigger(); }
  void grabInto(Frame& frame, std::chrono::milliseconds timeout) override { inner_->grabInto(frame, timeout); }
  StreamStatistics statistics() const override { return inner_->statistics(); }
  std::string getFeature(const std::string& n) override { return inner_->getFeature(n); }
  void setFeature(const std::string& n, const std::string& v) override { inner_->setFeature(n, v); }
  std::int64_t getIntegerFeature(const std::string& n) override { return inner_->getIntegerFeature(n); }
  void setIntegerFeature(const std::string& n, std::int64_t v) override { inner_->setIntegerFeature(n, v); }
  double getFloatFeature(const std::string& n) override { return inner_->getFloatFeature(n); }
  void setFloatFeature(const std::string& n, double v) override { inner_->setFloatFeature(n, v); }
  void executeCommand(const std::string& n) override { inner_->executeCommand(n); }

 protected:
  Camera& inner() { return *inner_; }

 private:
  std::unique_ptr<Camera> inner_;
};

}  // namespace lfi::testing_support
