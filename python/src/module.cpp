// SPDX-License-Identifier: Apache-2.0
// The Python package's native module, lfi._lfi (python/lfi/__init__.py re-exports it; docs/python.md).

#include "bindings.h"

#include "lfi/controller/coded_capture.h"  // registerControllerBackends
#include "lfi/core/error.h"
#include "lfi/drivers/builtin_backends.h"  // registerDriverBackends
#include "lfi/sim/devices/sim_camera.h"    // registerSimBackends

#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <filesystem>
#include <optional>

namespace fs = std::filesystem;

namespace lfi::python {

namespace {

// An error's kind as Python names it: the enumerator's name (core/error.h).
const char* codeName(Errc code) {
  switch (code) {
    case Errc::InvalidArgument:
      return "InvalidArgument";
    case Errc::InvalidFile:
      return "InvalidFile";
    case Errc::Checksum:
      return "Checksum";
    case Errc::Io:
      return "Io";
    case Errc::Exists:
      return "Exists";
    case Errc::NotFound:
      return "NotFound";
    case Errc::Config:
      return "Config";
    case Errc::Device:
      return "Device";
    case Errc::Timeout:
      return "Timeout";
    case Errc::Cancelled:
      return "Cancelled";
  }
  return "Unknown";
}

// The bench file as Python holds it.
struct PyBench {
  BenchFile bench;
  BenchFile devicesWith(const std::optional<fs::path>& part) const {
    return part ? withSimulatedPart(bench, *part) : bench;
  }
};

}  // namespace

}  // namespace lfi::python

PYBIND11_MODULE(_lfi, m) {
  namespace py = pybind11;
  using namespace lfi;
  using namespace lfi::python;
  m.doc() = "lfi's native module: the Python package lfi re-exports it (docs/python.md).";
  m.attr("__version__") = LFI_VERSION;
  // Every backend the command line has: aravis:, usb:, window:, sim:, coded:.
  registerDriverBackends();
  sim::registerSimBackends();
  registerControllerBackends();

  // lfi::Error as lfi.Error (a RuntimeError), its code as a string attribute.
  static py::exception<Error> error(m, "Error", PyExc_RuntimeError);
  error.doc() = "An lfi error: the message names the file, field or device; code says what kind.";
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const Error& e) {
      py::object instance = static_cast<py::object&>(error)(e.what());  // (the type called: an instance)
      instance.attr("code") = codeName(e.code());
      PyErr_SetObject(error.ptr(), instance.ptr());
    }
  });

  bindRecords(m);
  bindRun(m);
  bindDevices(m);
  bindLightFields(m);

  py::class_<PyBench>(m, "Bench", "A bench file, read and checked (docs/inspection.md).")
      .def(py::init([](const fs::path& path) { return PyBench{readBenchFile(path)}; }), py::arg("path"),
           "Reads and checks the bench file; lfi.Error naming the file, line and key for a malformed one.")
      .def_property_readonly("file", [](const PyBench& b) { return b.bench.file.string(); })
      .def_property_readonly("camera_uri", [](const PyBench& b) { return b.bench.cameraUri.text(); })
      .def_property_readonly("display_uri", [](const PyBench& b) { return b.bench.displayUri.text(); })
      .def_property_readonly("reference_folder", [](const PyBench& b) { return b.bench.referenceFolder.string(); })
      .def_property_readonly("output_folder", [](const PyBench& b) { return b.bench.outputFolder.string(); })
      .def(
          "capture",
          [](const PyBench& b, bool force) {
            py::gil_scoped_release release;
            captureReference(b.bench, force ? Overwrite::Allow : Overwrite::Refuse);
            return b.bench.referenceFolder.string();
          },
          py::arg("force") = false,
          "Takes the bench's reference package (`lfi capture`) and returns its folder; force replaces one there.")
      .def(
          "train",
          [](const PyBench& b, int images, const std::optional<fs::path>& part) {
            const BenchFile devices = b.devicesWith(part);
            py::gil_scoped_release release;
            return trainGoldenModel(b.bench, devices, images);
          },
          py::arg("images") = 1, py::arg("part") = py::none(),
          "Adds images of good parts to the golden model (`lfi train`); part: a simulated bench's part scene. "
          "Returns the images the model holds.")
      .def(
          "inspect",
          [](const PyBench& b, const std::optional<fs::path>& part, const std::optional<fs::path>& out) {
            const BenchFile devices = b.devicesWith(part);
            py::gil_scoped_release release;
            InspectResult r = inspectOnePart(b.bench, devices, out.value_or(fs::path()));
            return PyRecord{std::move(r.record), std::move(r.part.image), std::move(r.folder)};
          },
          py::arg("part") = py::none(), py::arg("out") = py::none(),
          "Inspects one part (`lfi inspect`): its record and images written into out (default: a new folder in "
          "the bench's [output] folder). part: a simulated bench's part scene.")
      .def(
          "run",
          [](const PyBench& b, std::optional<long> parts, std::optional<double> seconds,
             const std::optional<fs::path>& part, const std::optional<fs::path>& out) {
            return std::make_unique<PyRun>(b.bench, b.devicesWith(part), parts.value_or(0), seconds.value_or(0),
                                           out.value_or(fs::path()));
          },
          py::arg("parts") = py::none(), py::arg("seconds") = py::none(), py::arg("part") = py::none(),
          py::arg("out") = py::none(),
          "Starts a run (`lfi run`): parts inspected one after another until parts or seconds are reached or it "
          "is stopped, records and a summary in out (default: a new folder in the bench's [output] folder). "
          "Iterate it for the records as they come; Ctrl-C ends it after the part in hand.")
      .def("__repr__", [](const PyBench& b) { return "<lfi.Bench " + b.bench.file.string() + ">"; });
}
