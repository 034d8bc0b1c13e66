// SPDX-License-Identifier: Apache-2.0
// Record and Defect: an inspected part's verdict, defects, image and written record.

#include "bindings.h"

#include "lfi/core/error.h"

#include <fmt/format.h>
#include <pybind11/stl.h>

#include <optional>
#include <utility>

namespace lfi::python {

namespace {

std::pair<double, double> pair(const Vec2& v) {
  return {v.x, v.y};
}

}  // namespace

py::array imageArray(const cv::Mat& image) {
  if (image.channels() != 1) fail(Errc::InvalidArgument, "an image of {} channels, not one", image.channels());
  const auto copy = [&](auto tag) {
    using T = decltype(tag);
    py::array_t<T> out({image.rows, image.cols});
    auto view = out.template mutable_unchecked<2>();
    for (int row = 0; row < image.rows; ++row) {
      const T* in = image.ptr<T>(row);
      for (int col = 0; col < image.cols; ++col) view(row, col) = in[col];
    }
    return py::array(std::move(out));
  };
  switch (image.depth()) {
    case CV_8U:
      return copy(std::uint8_t{});
    case CV_16U:
      return copy(std::uint16_t{});
    case CV_32F:
      return copy(float{});
    default:
      fail(Errc::InvalidArgument, "an image of OpenCV depth {}, not 8 or 16 bits or float", image.depth());
  }
}

void bindRecords(py::module_& m) {
  py::class_<PartDefect>(m, "Defect", "One defect of an inspected part, in the part's frame (mm).")
      .def_property_readonly(
          "centroid_mm", [](const PartDefect& d) { return pair(d.centroid_mm); }, "Its centroid (x, y), mm.")
      .def_property_readonly(
          "centroid_u_mm", [](const PartDefect& d) { return pair(d.centroidU_mm); },
          "The centroid's expanded uncertainty per axis, mm (the bench's coverage factor).")
      .def_property_readonly(
          "area_mm2", [](const PartDefect& d) { return d.area_mm2; }, "Its area on the part, mm².")
      .def_property_readonly(
          "peak_contrast", [](const PartDefect& d) { return d.image.peakContrast; },
          "Its strongest relative difference from the golden model (negative: darker).")
      .def_property_readonly(
          "inside_mm",
          [](const PartDefect& d) -> std::optional<std::pair<double, double>> {
            if (!d.inside_mm) return std::nullopt;
            return pair(*d.inside_mm);
          },
          "Where it is inside the part at the bench's defect depth (with the part's model), or None.")
      .def("__repr__", [](const PartDefect& d) {
        return fmt::format("<lfi.Defect at ({:.2f}, {:.2f}) mm, {:.3g} mm², contrast {:+.2f}>", d.centroid_mm.x,
                           d.centroid_mm.y, d.area_mm2, d.image.peakContrast);
      });

  py::class_<PyRecord>(m, "Record", "One part's record: its verdict, defects, image and the record written.")
      .def_property_readonly(
          "part", [](const PyRecord& r) { return r.record.part; }, "The part's number (1 for a single inspection).")
      .def_property_readonly(
          "time_utc", [](const PyRecord& r) { return r.record.time_utc; }, "When it was inspected, ISO 8601 UTC.")
      .def_property_readonly(
          "verdict",
          [](const PyRecord& r) -> std::string {
            if (!r.record.verdict) return "error";
            return r.record.verdict->pass ? "pass" : "fail";
          },
          "\"pass\", \"fail\", or \"error\" for a part that could not be inspected (error says why).")
      .def_property_readonly(
          "passed", [](const PyRecord& r) { return r.record.verdict && r.record.verdict->pass; },
          "Whether the part passed.")
      .def_property_readonly(
          "error", [](const PyRecord& r) { return r.record.error; }, "Why the part was not inspected, or \"\".")
      .def_property_readonly(
          "reasons",
          [](const PyRecord& r) { return r.record.verdict ? r.record.verdict->reasons : std::vector<std::string>{}; },
          "One line per rule the part broke.")
      .def_property_readonly(
          "defects",
          [](const PyRecord& r) { return r.record.verdict ? r.record.verdict->defects : std::vector<PartDefect>{}; },
          "Its defects, largest first.")
      .def_property_readonly(
          "analysis_ms", [](const PyRecord& r) { return r.record.analysis_ms; },
          "From the image in hand to the verdict, ms.")
      .def_property_readonly(
          "image",
          [](const PyRecord& r) -> py::object {
            if (r.image.empty()) return py::none();
            return imageArray(r.image);
          },
          "The part's image (the mean of the bench's frames), DN, float32 (rows, cols), a copy; None for a run's "
          "record (its images are in the run's folder).")
      .def_property_readonly(
          "folder", [](const PyRecord& r) { return r.folder.string(); }, "The folder of its record and images.")
      .def_property_readonly(
          "json", [](const PyRecord& r) { return recordText(r.record, 2); }, "The record as written (JSON).")
      .def("__repr__", [](const PyRecord& r) {
        const std::size_t defects = r.record.verdict ? r.record.verdict->defects.size() : 0;
        return fmt::format("<lfi.Record part {}: {} with {} defects>", r.record.part,
                           !r.record.verdict        ? "error"
                           : r.record.verdict->pass ? "pass"
                                                    : "fail",
                           defects);
      });
}

}  // namespace lfi::python
