// SPDX-License-Identifier: Apache-2.0
#pragma once
// The Python package's pieces (module.cpp binds them).

#include "lfi/controller/run.h"
#include "lfi/session/bench_session.h"

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <opencv2/core.hpp>

#include <atomic>
#include <condition_variable>
#include <deque>
#include <exception>
#include <filesystem>
#include <mutex>
#include <thread>

namespace lfi::python {

namespace py = pybind11;

// A copy of a single-channel image as a numpy array of its element type (uint8, uint16, float32), shape (rows, cols).
py::array imageArray(const cv::Mat& image);

// Binds Defect and Record.
void bindRecords(py::module_& m);

// One part's record as Python sees it: a single inspection's (with its image) or a run's (its image in the
// run's folder).
struct PyRecord {
  InspectionRecord record;
  cv::Mat image;  // CV_32FC1 DN, or empty
  std::filesystem::path folder;
};

// A run on a thread of its own (run.cpp): its records as they come.
class PyRun {
 public:
  PyRun(const BenchFile& bench, const BenchFile& devices, long parts, double seconds,
        const std::filesystem::path& folder);
  ~PyRun();
  PyRun(const PyRun&) = delete;
  PyRun& operator=(const PyRun&) = delete;
  // The next record (the GIL released while waiting); py::stop_iteration at the end, the run's error
  // rethrown, KeyboardInterrupt after the part in hand.
  PyRecord next();
  void stop();
  const std::filesystem::path& folder() const { return options_.folder; }

 private:
  BenchFile bench_, devices_;
  ReferencePackage package_;
  RunOptions options_;
  RunResult result_;
  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable ready_;
  std::deque<InspectionRecord> queue_;
  bool done_ = false;
  std::exception_ptr error_;
  std::atomic<bool> stop_{false};
};

// Binds Run.
void bindRun(py::module_& m);

// Binds Camera, FrameView, Display, open_camera and open_display (devices.cpp).
void bindDevices(py::module_& m);

// Binds LightField, read_light_field, write_light_field and render (light_fields.cpp).
void bindLightFields(py::module_& m);

}  // namespace lfi::python
