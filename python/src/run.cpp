// SPDX-License-Identifier: Apache-2.0
// bench.run(): a run (`lfi run`, controller/run.h) on a thread of its own, its records handed to Python as an
// iterator; Ctrl-C (KeyboardInterrupt) ends it after the part in hand.

#include "bindings.h"

#include "lfi/controller/run.h"
#include "lfi/core/error.h"

#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <thread>

namespace fs = std::filesystem;

namespace lfi::python {

PyRun::PyRun(const BenchFile& bench, const BenchFile& devices, long parts, double seconds, const fs::path& folder)
    : bench_(bench), devices_(devices) {
  options_.folder = folder.empty() ? bench.outputFolder / timedFolderName("run", utcNow()) : folder;
  options_.parts = parts;
  options_.seconds = seconds;
  options_.partModel = benchPartModel(bench);
  options_.stopRequested = [this] { return stop_.load(); };
  options_.onRecord = [this](const InspectionRecord& record) {
    {
      const std::lock_guard lock(mutex_);
      queue_.push_back(record);
    }
    ready_.notify_one();
  };
  package_ = readReferencePackage(bench.referenceFolder, &bench);
  thread_ = std::thread([this] {
    try {
      result_ = runParts(bench_, devices_, package_, options_);
    } catch (...) {
      error_ = std::current_exception();
    }
    {
      const std::lock_guard lock(mutex_);
      done_ = true;
    }
    ready_.notify_one();
  });
}

PyRun::~PyRun() {
  stop();
}

void PyRun::stop() {
  stop_ = true;
  if (thread_.joinable()) {
    py::gil_scoped_release release;
    thread_.join();
  }
}

PyRecord PyRun::next() {
  for (;;) {
    {
      py::gil_scoped_release release;
      std::unique_lock lock(mutex_);
      ready_.wait_for(lock, std::chrono::milliseconds(100), [this] { return !queue_.empty() || done_; });
      if (!queue_.empty()) {
        PyRecord r{std::move(queue_.front()), cv::Mat(), options_.folder};
        queue_.pop_front();
        return r;
      }
      if (done_) break;
    }
    if (PyErr_CheckSignals() != 0) {  // Ctrl-C: the part in hand finishes, then the KeyboardInterrupt goes on
      const py::error_already_set interrupt;
      stop();
      throw interrupt;
    }
  }
  stop();
  if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
  // The outputs' trouble ([output.mqtt]) as warnings: the run's records are all in its file.
  for (const std::string& problem : std::exchange(result_.outputProblems, {}))
    if (PyErr_WarnEx(PyExc_RuntimeWarning, problem.c_str(), 1) != 0) throw py::error_already_set();
  throw py::stop_iteration();
}

void bindRun(py::module_& m) {
  py::class_<PyRun>(m, "Run",
                    "A run's records as they come (iterate it); Ctrl-C or stop() ends it after the part "
                    "in hand. A with block stops it on leaving.")
      .def("__iter__", [](py::object self) { return self; })
      .def("__next__", &PyRun::next)
      .def("stop", &PyRun::stop, "Ends the run after the part in hand and waits for it.")
      .def("__enter__", [](py::object self) { return self; })
      .def("__exit__", [](PyRun& r, py::args) { r.stop(); })
      .def_property_readonly(
          "folder", [](const PyRun& r) { return r.folder().string(); },
          "The run's folder: records.jsonl, summary.html, images/.")
      .def_property_readonly(
          "records_file", [](const PyRun& r) { return (r.folder() / "records.jsonl").string(); },
          "Its JSON Lines records.");
}

}  // namespace lfi::python
