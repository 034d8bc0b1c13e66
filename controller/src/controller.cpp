// SPDX-License-Identifier: Apache-2.0
#include "lfi/controller/controller.h"

#include "lfi/controller/frame_correction.h"

#include "lfi/core/error.h"
#include "lfi/core/image.h"
#include "lfi/core/log.h"
#include "lfi/drivers/display_optics.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <thread>
#include <vector>

namespace lfi {
namespace {

// The display's id for a message (its info() has a state of its own to refuse in).
std::string displayName(const Display& display) {
  try {
    return display.info().deviceId;
  } catch (const Error&) {
    return "(its id unknown)";
  }
}

}  // namespace

// The bench as a capture through it sees it: the controller's own show and inspect.
class Controller::Probe final : public BenchProbe {
 public:
  explicit Probe(Controller& c) : c_(c) {}
  DisplayInfo display() const override { return c_.display_.info(); }
  double cameraFullScale_dn() const override { return (1 << significantBits(c_.camera_.settings().pixelFormat)) - 1; }
  cv::Mat take(const cv::Mat& levels) override {
    c_.showPanel(levels);
    return c_.inspect();
  }

 private:
  Controller& c_;
};

Controller::Controller(LightFieldCapture& capture, Display& display, Camera& camera, ControllerOptions options)
    : capture_(capture), display_(display), camera_(camera), options_(options) {
  if (options_.frames < 1) fail(Errc::InvalidArgument, "controller: frames = {} must be >= 1", options_.frames);
  if (options_.retries < 0) fail(Errc::InvalidArgument, "controller: retries = {} must be >= 0", options_.retries);
  if (options_.grabTimeout.count() <= 0) fail(Errc::InvalidArgument, "controller: grabTimeout must be positive");
  if (!(options_.white >= 0)) fail(Errc::InvalidArgument, "controller: white = {} must be >= 0", options_.white);
  if (options_.settle.count() < 0)
    fail(Errc::InvalidArgument, "controller: settle = {} ms must be >= 0", options_.settle.count());
}

BenchProbe& Controller::probe() {
  if (!probe_) probe_ = std::make_unique<Probe>(*this);
  return *probe_;
}

Controller::~Controller() {
  if (startedCamera_ && camera_.state() == Camera::State::Streaming) {
    try {
      camera_.stop();
    } catch (const std::exception& e) {
      spdlog::warn("controller: stopping the camera failed: {}", e.what());
    }
  }
}

LightField Controller::captureReference(const Progress& progress) {
  spdlog::info("capture: {}", capture_.description());
  referencePanel_ = cv::Mat();
  const auto report = [&](double f) {
    if (progress) progress("capture", f);
  };
  if (!capture_.measuresThroughBench()) return capture_.capture(report);
  capture_.setBench(&probe());
  struct Detach {
    LightFieldCapture& capture;
    ~Detach() { capture.setBench(nullptr); }
  } detach{capture_};
  LightField lightField = capture_.capture(report);
  referencePanel_ = capture_.panelImage();
  return lightField;
}

double Controller::defaultWhite(const LightField& lightField) {
  // The 99.9th percentile: a few hot samples must not darken the whole panel.
  const double white = percentile(lightField.lensletImage(), 0.999);
  return white > 0 ? white : 1.0;
}

void Controller::emit(const LightField& reference) {
  emit(reference, options_.white > 0 ? options_.white : defaultWhite(reference));
}

void Controller::emit(const LightField& reference, double white) {
  if (!(white > 0) || !std::isfinite(white))
    fail(Errc::InvalidArgument, "emit: white = {} must be positive and finite", white);
  white_ = white;
  // From here on, frames the camera has exposed show the old panel, and frames
  // of a stream started before the panel settles may too (the caller may start
  // one after this): inspect() waits for the panel and (re)starts the stream.
  staleFrames_ = true;
  const cv::Mat panel = encodeLightField(reference, DisplayOptics(display_.info()), white_,
                                         LightFieldLookup::Interpolated, panelResponse());
  const std::uint32_t sequence = shown(display_.show(panel), "the light field");
  spdlog::info("emit: light field shown (sequence {}, white = {:.4g})", sequence, white_);
}

void Controller::showPanel(const cv::Mat& levels) {
  const cv::Mat panel = panelFromLevels(levels, display_.info(), panelResponse());
  white_ = 1;
  staleFrames_ = true;  // (as emit())
  shown(display_.show(panel), "the panel image");
}

const PanelResponse* Controller::panelResponse() {
  if (!options_.panelResponse) return nullptr;
  if (!panelResponse_) {
    try {
      panelResponse_ = std::make_unique<const PanelResponse>(*options_.panelResponse, display_.info());
    } catch (const Error& e) {
      fail(Errc::Config, "display '{}': its panel response: {}", displayName(display_), e.what());
    }
  }
  return panelResponse_.get();
}

void Controller::emitReference(const LightField& reference) {
  if (referencePanel_.empty())
    emit(reference);
  else
    showPanel(referencePanel_);
}

std::uint32_t Controller::shown(const PresentResult& r, const char* what) {
  if (r.status != PresentStatus::Presented)
    fail(Errc::Device, "emit: display '{}' did not show {} ({}{}{})", displayName(display_), what, toString(r.status),
         r.message.empty() ? "" : ": ", r.message);
  shown_ = std::chrono::steady_clock::now();
  shownSequence_ = r.sequence;
  return r.sequence;
}

void Controller::requireShowing() {
  if (!shownSequence_)
    fail(Errc::InvalidArgument, "inspect: display '{}' was not sent anything to show", displayName(display_));
  const DisplayStatus s = display_.status();
  if (!s.showing || s.presentedSequence != *shownSequence_)
    fail(Errc::Device,
         "inspect: display '{}' no longer shows the reference (frame {} was shown; it {}): the image "
         "taken is not of the reference",
         displayName(display_), *shownSequence_,
         s.showing ? fmt::format("shows frame {}", s.presentedSequence) : std::string("is dark"));
}

cv::Mat Controller::inspect() {
  cv::Mat image = meanOfFrames();
  if (options_.correction) options_.correction->apply(image);
  return image;
}

cv::Mat Controller::meanOfFrames() {
  // Frames exposed before the last emit() wait in the camera's buffers (a
  // free-running camera fills them; a late triggered frame may too): start a
  // new acquisition, so that every frame averaged is exposed after it, unless
  // the stream is a software-triggered one of ours that every trigger has been
  // answered on (it holds no frame). A trigger of ours still unanswered may be
  // answered yet, by a frame of the part before: restart then too, new panel or
  // not. The stream stays whoever's it was.
  // Frames are averaged as they arrive: a few buffers beyond them ride out a
  // stall of this thread; more would only hold memory (a 4K Mono16 frame is
  // 16 MB). A frame lost to a full pool is an underrun, not a bad frame.
  const int buffers = std::clamp(options_.frames, 2, 14) + 2;
  const bool streaming = camera_.state() == Camera::State::Streaming;
  const bool ours = streaming && ownStream_ && ownSoftware_;
  const bool empty = ours && pendingFrames_ == 0, late = ours && pendingFrames_ > 0;
  const bool restart = (streaming && staleFrames_ && !empty) || late;
  if ((streaming && staleFrames_) || camera_.state() == Camera::State::Configured)
    std::this_thread::sleep_until(shown_ + options_.settle);  // the panel settles before the first exposure
  if (restart || camera_.state() == Camera::State::Configured) {
    if (restart)
      camera_.stop();
    else
      startedCamera_ = true;
    camera_.start(buffers);
    ownStream_ = true;
    pendingFrames_ = 0;
  }
  staleFrames_ = false;
  if (camera_.state() != Camera::State::Streaming)
    fail(Errc::InvalidArgument, "inspect: the camera must be configured or streaming (it is {})",
         toString(camera_.state()));
  const CameraSettings settings = camera_.settings();
  const bool software = settings.trigger == TriggerMode::Software;
  ownSoftware_ = software;  // (a streaming camera's settings do not change)
  // A frame takes its exposure, and as long again for readout and transfer at most, beyond the option's wait.
  // (At most a day more, checkedGrabTimeout's cap; none for an exposure that is not a number.)
  const double extra_ms = std::min(std::max(0.0, 2 * settings.exposure_us / 1000), 86'400'000.0);
  const auto timeout = options_.grabTimeout + std::chrono::milliseconds(static_cast<std::int64_t>(std::ceil(extra_ms)));
  const std::string camera = camera_.info().deviceId;
  cv::Mat sum;  // (in double: a float sum of 16-bit frames stops being exact past 256 of them)
  int good = 0, bad = 0, timeouts = 0;
  Frame frame;
  while (good < options_.frames) {
    if (software) {
      camera_.softwareTrigger();
      ++pendingFrames_;
    }
    camera_.grabInto(frame, timeout);
    if (software && frame.status != FrameStatus::Timeout) pendingFrames_ = std::max(0, pendingFrames_ - 1);
    if (frame.status != FrameStatus::Complete) {
      (frame.status == FrameStatus::Timeout ? timeouts : bad) += 1;
      if (bad + timeouts > options_.retries) {
        if (good == 0 && bad == 0)
          fail(Errc::Timeout, "inspect: no frame from camera '{}' in {} tries of {} ms", camera, timeouts,
               timeout.count());
        fail(Errc::Device, "inspect: camera '{}' gave {} incomplete and {} timed-out frames (more than {} allowed)",
             camera, bad, timeouts, options_.retries);
      }
      continue;
    }
    if (options_.frames == 1) {  // (the frame itself: no sum to keep exact)
      cv::Mat image;
      frame.image.convertTo(image, CV_32F);
      return image;
    }
    cv::Mat f;
    frame.image.convertTo(f, CV_64F);
    if (sum.empty())
      sum = f;
    else if (f.size() != sum.size())
      fail(Errc::Device, "inspect: camera '{}' changed its image size mid-inspection", camera);
    else
      sum += f;
    ++good;
  }
  cv::Mat mean;
  sum.convertTo(mean, CV_32F, 1.0 / good);
  return mean;
}

cv::Mat Controller::run(const Progress& progress) {
  const LightField reference = captureReference(progress);
  if (progress) progress("emit", 0);
  emitReference(reference);
  if (progress) progress("inspect", 0);
  cv::Mat image = inspect();
  if (progress) progress("inspect", 1);
  return image;
}

}  // namespace lfi
