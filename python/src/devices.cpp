// SPDX-License-Identifier: Apache-2.0
// lfi.open_camera and lfi.open_display: a bench's devices alone, by URI (drivers' registries), frames as numpy.

#include "bindings.h"

#include "lfi/core/error.h"
#include "lfi/drivers/camera_registry.h"
#include "lfi/drivers/display_registry.h"

#include <fmt/format.h>
#include <pybind11/stl.h>

#include <chrono>
#include <memory>

namespace lfi::python {

namespace {

PixelFormat pixelFormat(const std::string& name) {
  for (const PixelFormat f : {PixelFormat::Mono8, PixelFormat::Mono12, PixelFormat::Mono16})
    if (name == toString(f)) return f;
  fail(Errc::InvalidArgument, "pixel_format '{}': Mono8, Mono12 or Mono16", name);
}

TriggerMode triggerMode(const std::string& name) {
  for (const TriggerMode t : {TriggerMode::FreeRun, TriggerMode::Software, TriggerMode::Line})
    if (name == toString(t)) return t;
  fail(Errc::InvalidArgument, "trigger '{}': {}, {} or {}", name, toString(TriggerMode::FreeRun),
       toString(TriggerMode::Software), toString(TriggerMode::Line));
}

// A camera and its settings as Python drives it: configured at open, streaming from the first grab.
struct PyCamera {
  std::unique_ptr<Camera> camera;
  int buffers = 4;
  Frame viewFrame;        // what fetch() grabs into, its memory reused from frame to frame
  bool viewOpen = false;  // a FrameView over viewFrame is inside its with block

  // The next frame into `frame` (a software trigger first when the camera is so triggered), the GIL released.
  void grabInto(Frame& frame, double timeout_ms) {
    {
      py::gil_scoped_release release;
      if (camera->state() != Camera::State::Streaming) camera->start(buffers);
      if (camera->settings().trigger == TriggerMode::Software) camera->softwareTrigger();
      camera->grabInto(frame, std::chrono::milliseconds(static_cast<long>(timeout_ms)));
    }
    if (frame.status == FrameStatus::Timeout)
      fail(Errc::Timeout, "camera '{}': no frame within {} ms", camera->info().deviceId, timeout_ms);
  }
};

// A frame fetched without a copy: its image a numpy view of the camera's own buffer, read inside the with
// block. Each view holds a reference to the buffer, and a camera never writes into a buffer someone else
// holds (camera.h's grabInto reuses it only when it is the last), so a view kept past its block stays its
// frame and memory-safe; once the views are gone, the next fetch reuses the memory.
struct PyFrameView {
  PyCamera* camera;
  py::object owner;  // the Python camera, kept alive while the view is
  bool open = true;

  const Frame& frame() const {
    if (!open) fail(Errc::InvalidArgument, "this frame view is closed: its with block ended (grab() copies)");
    return camera->viewFrame;
  }
  void close() {
    if (open) camera->viewOpen = false;
    open = false;
  }
};

// A numpy view of `image` (no copy) whose base keeps its memory alive.
py::array imageView(const cv::Mat& image) {
  auto* held = new cv::Mat(image);  // (one more reference to the buffer, released with the array)
  const py::capsule base(held, [](void* p) { delete static_cast<cv::Mat*>(p); });
  const auto view = [&](auto tag) {
    using T = decltype(tag);
    return py::array(py::array_t<T>({image.rows, image.cols},
                                    {static_cast<py::ssize_t>(image.step[0]), static_cast<py::ssize_t>(sizeof(T))},
                                    reinterpret_cast<const T*>(image.data), base));
  };
  if (image.depth() == CV_8U) return view(std::uint8_t{});
  if (image.depth() == CV_16U) return view(std::uint16_t{});
  fail(Errc::InvalidArgument, "a frame of OpenCV depth {}, not 8 or 16 bits", image.depth());
}

py::dict frameDict(Frame& frame) {
  py::dict d;
  d["image"] = imageArray(frame.image);
  d["frame_id"] = frame.frameId;
  d["timestamp_ns"] = frame.timestamp_ns;
  d["status"] = toString(frame.status);
  return d;
}

}  // namespace

void bindDevices(py::module_& m) {
  py::class_<PyCamera>(m, "Camera", "A camera opened by URI (sim:, aravis:), configured; frames as numpy arrays.")
      .def_property_readonly("info",
                             [](const PyCamera& c) {
                               const CameraInfo i = c.camera->info();
                               py::dict d;
                               d["vendor"] = i.vendor;
                               d["model"] = i.model;
                               d["serial"] = i.serial;
                               d["device_id"] = i.deviceId;
                               d["sensor_px"] = py::make_tuple(i.sensorWidth_px, i.sensorHeight_px);
                               return d;
                             })
      .def(
          "grab",
          [](PyCamera& c, double timeout_ms) {
            Frame frame;
            c.grabInto(frame, timeout_ms);
            return frameDict(frame);
          },
          py::arg("timeout_ms") = 1000.0,
          "The next frame (a software trigger first when the camera is so triggered): a dict of image (numpy "
          "uint8 for Mono8, uint16 for Mono12 and Mono16, a copy), frame_id, timestamp_ns and status "
          "(\"Complete\", \"Incomplete\"). lfi.Error (code \"Timeout\") when none comes in time.")
      .def(
          "fetch",
          [](py::object self, double timeout_ms) {
            PyCamera& c = self.cast<PyCamera&>();
            if (c.viewOpen)
              fail(Errc::InvalidArgument,
                   "camera '{}': a frame view is open; leave its with block before the next fetch()",
                   c.camera->info().deviceId);
            c.grabInto(c.viewFrame, timeout_ms);
            c.viewOpen = true;
            return PyFrameView{&c, self};
          },
          py::arg("timeout_ms") = 1000.0,
          "The next frame without a copy, for a with block: `with camera.fetch() as frame: frame.image` is a "
          "numpy view of the camera's own buffer. The next fetch() reuses that memory, unless a view of it is "
          "still held: the camera then takes other memory and never overwrites it. grab() copies. One "
          "FrameView at a time.")
      .def(
          "close", [](PyCamera& c) { c.camera->close(); }, "Closes the camera.")
      .def("__enter__", [](py::object self) { return self; })
      .def("__exit__", [](PyCamera& c, py::args) { c.camera->close(); });

  py::class_<PyFrameView>(m, "FrameView", "A frame fetched without a copy (Camera.fetch), valid in its with block.")
      .def_property_readonly(
          "image", [](const PyFrameView& v) { return imageView(v.frame().image); },
          "The frame as a numpy view (uint8 for Mono8, uint16 for Mono12 and Mono16), no copy.")
      .def_property_readonly(
          "frame_id", [](const PyFrameView& v) { return v.frame().frameId; }, "The device's frame counter.")
      .def_property_readonly(
          "timestamp_ns", [](const PyFrameView& v) { return v.frame().timestamp_ns; },
          "The device's clock at the frame, ns.")
      .def_property_readonly(
          "status", [](const PyFrameView& v) { return std::string(toString(v.frame().status)); },
          "\"Complete\" or \"Incomplete\".")
      .def("__enter__", [](py::object self) { return self; })
      .def("__exit__", [](PyFrameView& v, py::args) { v.close(); })
      .def("close", &PyFrameView::close, "Ends the view, as leaving its with block does.");

  m.def(
      "open_camera",
      [](const std::string& uri, double exposure_us, const std::string& format, const std::string& trigger,
         double gain) {
        auto c = std::make_unique<PyCamera>();
        CameraSettings settings;
        settings.exposure_us = exposure_us;
        settings.pixelFormat = pixelFormat(format);
        settings.trigger = triggerMode(trigger);
        settings.gain = gain;
        py::gil_scoped_release release;
        c->camera = openCamera(uri);
        c->camera->configure(settings);
        return c;
      },
      py::arg("uri"), py::arg("exposure_us") = 10000.0, py::arg("pixel_format") = "Mono8",
      py::arg("trigger") = "Software", py::arg("gain") = 0.0,
      "Opens and configures a camera by URI (docs/camera.md): sim:SCENE, aravis:ID.");

  py::class_<Display>(m, "Display", "A display opened by URI (sim:, usb:, window:); panels from numpy arrays.")
      .def_property_readonly("info",
                             [](const Display& d) {
                               const DisplayInfo i = d.info();
                               py::dict out;
                               out["vendor"] = i.vendor;
                               out["model"] = i.model;
                               out["device_id"] = i.deviceId;
                               out["panel_px"] = py::make_tuple(i.panelWidth_px, i.panelHeight_px);
                               out["pixel_pitch_mm"] = i.pixelPitch_mm;
                               out["optics"] = toString(i.optics.type);
                               out["channels"] = i.subpixelsPerPixel();
                               return out;
                             })
      .def(
          "show",
          [](Display& d, py::array_t<std::uint8_t, py::array::c_style | py::array::forcecast> panel) {
            const DisplayInfo info = d.info();
            const int channels = info.subpixelsPerPixel();
            const bool shaped = channels == 1 ? panel.ndim() == 2 : panel.ndim() == 3 && panel.shape(2) == channels;
            if (!shaped || panel.shape(0) != info.panelHeight_px || panel.shape(1) != info.panelWidth_px) {
              std::string shape;
              for (py::ssize_t k = 0; k < panel.ndim(); ++k) shape += (k ? " x " : "") + std::to_string(panel.shape(k));
              fail(Errc::InvalidArgument, "display '{}': a panel of {} x {}{} uint8 levels, not {}", info.deviceId,
                   info.panelHeight_px, info.panelWidth_px, channels == 1 ? "" : fmt::format(" x {}", channels), shape);
            }
            const cv::Mat levels(info.panelHeight_px, info.panelWidth_px, info.panelType(),
                                 const_cast<std::uint8_t*>(panel.data()));
            PresentResult r;
            {
              py::gil_scoped_release release;
              r = d.show(levels);
            }
            if (r.status != PresentStatus::Presented)
              fail(r.status == PresentStatus::Timeout ? Errc::Timeout : Errc::Device, "display '{}': {} ({})",
                   info.deviceId, toString(r.status), r.message);
          },
          py::arg("panel"),
          "Shows a panel: uint8 drive levels of shape (rows, cols), or (rows, cols, 3) on an RGB panel.")
      .def(
          "close", [](Display& d) { d.close(); }, "Closes the display.")
      .def("__enter__", [](py::object self) { return self; })
      .def("__exit__", [](Display& d, py::args) { d.close(); });

  m.def(
      "open_display",
      [](const std::string& uri) {
        py::gil_scoped_release release;
        return openDisplay(uri);
      },
      py::arg("uri"), "Opens a display by URI (docs/display.md): sim:SCENE, usb:SERIAL, window:INDEX.");
}

}  // namespace lfi::python
