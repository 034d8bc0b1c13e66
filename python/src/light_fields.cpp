// SPDX-License-Identifier: Apache-2.0
// lfi.LightField, read_light_field, write_light_field and render: light fields
// (core/light_field.h, in the same parametrisation) and the ray tracer from
// Python, as numpy arrays.

#include "bindings.h"

#include "lfi/core/error.h"
#include "lfi/core/exr_io.h"
#include "lfi/core/light_field.h"
#include "lfi/sim/render.h"
#include "lfi/sim/scene.h"
#include "lfi/sim/scene_file.h"

#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <atomic>
#include <chrono>
#include <optional>

namespace lfi::python {

namespace fs = std::filesystem;

namespace {

// A float32 (rows, cols) array as a CV_32FC1 image (a copy).
cv::Mat floatImage(const py::array_t<float, py::array::c_style | py::array::forcecast>& a, const char* what) {
  if (a.ndim() != 2) fail(Errc::InvalidArgument, "{}: a 2-D array (rows, cols), not {}-D", what, a.ndim());
  return cv::Mat(static_cast<int>(a.shape(0)), static_cast<int>(a.shape(1)), CV_32FC1, const_cast<float*>(a.data()))
      .clone();
}

// Renders on a thread of its own while this one, holding the GIL for an instant every 100 ms, lets
// Ctrl-C cancel it (between tiles).
cv::Mat renderInterruptibly(const sim::Scene& scene, const sim::Sensor& sensor, sim::RenderOptions options) {
  std::atomic<bool> cancel{false}, done{false};
  options.cancel = &cancel;
  cv::Mat image;
  std::exception_ptr error;
  std::thread worker([&] {
    try {
      image = sim::render(scene, sensor, options);
    } catch (...) {
      error = std::current_exception();
    }
    done = true;
  });
  std::optional<py::error_already_set> interrupt;
  while (!done) {
    {
      py::gil_scoped_release release;
      for (int i = 0; i < 20 && !done; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    if (!interrupt && PyErr_CheckSignals() != 0) {
      interrupt.emplace();
      cancel = true;
    }
  }
  worker.join();
  if (interrupt) throw *interrupt;
  if (error) std::rethrow_exception(error);
  return image;
}

}  // namespace

void bindLightFields(py::module_& m) {
  py::class_<LightField>(m, "LightField",
                         "A 4D light field in lfi's parametrisation (docs/file-formats.md): spatial elements "
                         "(sx, sy) of n x n angular samples on a pixel grid of pitch pixel_pitch_mm, stored as "
                         "a lenslet image of (sy n) x (sx n) float32 radiances; the plane's frame has +z towards "
                         "the part and the camera.")
      .def(py::init([](const py::array_t<float, py::array::c_style | py::array::forcecast>& lenslet, int angular,
                       double pixelPitch_mm, double distance_mm) {
             if (angular < 1) fail(Errc::InvalidArgument, "light field: angular = {}, not >= 1", angular);
             const cv::Mat image = floatImage(lenslet, "light field: lenslet");
             if (image.rows % angular != 0 || image.cols % angular != 0)
               fail(Errc::InvalidArgument, "light field: a lenslet image of {} x {} is not whole {} x {} elements",
                    image.rows, image.cols, angular, angular);
             LightFieldGeometry g;
             g.spatialX = image.cols / angular;
             g.spatialY = image.rows / angular;
             g.angular = angular;
             g.pixelPitch_mm = pixelPitch_mm;
             g.distance_mm = distance_mm;
             g.validate();
             return LightField(g, image);
           }),
           py::arg("lenslet"), py::arg("angular"), py::arg("pixel_pitch_mm"), py::arg("distance_mm") = 0.0,
           "From a lenslet image (float32 radiances >= 0, rows = sy n, cols = sx n).")
      .def_property_readonly(
          "spatial", [](const LightField& f) { return py::make_tuple(f.geometry().spatialX, f.geometry().spatialY); },
          "Spatial elements (sx, sy).")
      .def_property_readonly(
          "angular", [](const LightField& f) { return f.geometry().angular; }, "Angular samples per side, n.")
      .def_property_readonly(
          "pixel_pitch_mm", [](const LightField& f) { return f.geometry().pixelPitch_mm; },
          "The pixel grid's pitch p, mm.")
      .def_property_readonly(
          "element_pitch_mm", [](const LightField& f) { return f.geometry().elementPitch_mm(); },
          "A spatial element's pitch n p, mm.")
      .def_property_readonly(
          "distance_mm", [](const LightField& f) { return f.geometry().distance_mm; },
          "Δ recorded for the emitter, mm (0: not set).")
      .def_property_readonly(
          "lenslet", [](const LightField& f) { return imageArray(f.lensletImage()); },
          "The lenslet image, float32 (sy n, sx n), a copy: element (ex, ey)'s sample (u, v) at "
          "[ey n + v, ex n + u].")
      .def("__repr__", [](const LightField& f) {
        const LightFieldGeometry& g = f.geometry();
        return fmt::format("<lfi.LightField {} x {} elements of {} x {}, pitch {} mm, Δ = {} mm>", g.spatialX,
                           g.spatialY, g.angular, g.angular, g.pixelPitch_mm, g.distance_mm);
      });

  m.def(
      "read_light_field",
      [](const fs::path& path) {
        py::gil_scoped_release release;
        return readLightFieldExr(path);
      },
      py::arg("path"),
      "Reads a light field EXR file (its parametrisation from its header, its checksum checked); lfi.Error "
      "naming the file for a corrupt or foreign one.");
  m.def(
      "write_light_field",
      [](const fs::path& path, const LightField& field, bool overwrite) {
        py::gil_scoped_release release;
        writeLightFieldExr(path, field, overwrite ? Overwrite::Allow : Overwrite::Refuse);
      },
      py::arg("path"), py::arg("light_field"), py::arg("overwrite") = false,
      "Writes a light field EXR file atomically, its parametrisation in its header; an existing file is "
      "replaced only with overwrite=True (else lfi.Error, code \"Exists\").");
  m.def(
      "render",
      [](const fs::path& sceneFile, int spp, std::optional<std::uint64_t> seed, int threads) -> py::object {
        sim::SceneDescription d;
        {
          py::gil_scoped_release release;
          d = sim::loadSceneFile(sceneFile);
        }
        if (spp < 0) fail(Errc::InvalidArgument, "render: spp = {}, not >= 0", spp);
        if (spp > 0) d.render.samplesPerPixel = spp;
        if (seed) d.render.seed = *seed;
        d.render.threads = threads;
        const sim::Scene scene(std::move(d.objects), d.ambientIor);
        const cv::Mat image = renderInterruptibly(scene, d.sensor, d.render);
        if (const auto* lfs = std::get_if<sim::LightFieldSensor>(&d.sensor))
          return py::cast(LightField(lfs->geometry, image));
        return imageArray(image);
      },
      py::arg("scene"), py::arg("spp") = 0, py::arg("seed") = py::none(), py::arg("threads") = 0,
      "Renders a scene file (docs/scene-files.md) with the ray tracer: a camera scene's radiance image "
      "(float32, rows x cols), or a light field sensor's LightField. spp and seed override the file's (0, None: "
      "the file's); threads 0 uses every core. The GIL is released; Ctrl-C cancels between tiles.");
}

}  // namespace lfi::python
