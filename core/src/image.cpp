// SPDX-License-Identifier: Apache-2.0
#include "lfi/core/image.h"

#include "lfi/core/error.h"

#include <png.h>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

namespace lfi {

void requireImageType(const cv::Mat& image, int cvType, const std::string& what) {
  if (image.empty()) fail(Errc::InvalidArgument, "{} is empty", what);
  if (image.type() != cvType)
    fail(Errc::InvalidArgument, "{} has pixel type {}, expected {}", what, cv::typeToString(image.type()),
         cv::typeToString(cvType));
}

namespace {

// The first pixel (in row order) of a CV_32FC1 image where `bad` holds.
template <typename Predicate>
std::optional<cv::Point> firstPixelWhere(const cv::Mat& image, const char* what, Predicate bad) {
  requireImageType(image, CV_32FC1, what);
  for (int r = 0; r < image.rows; ++r) {
    const float* row = image.ptr<float>(r);
    for (int c = 0; c < image.cols; ++c)
      if (bad(row[c])) return cv::Point(c, r);
  }
  return std::nullopt;
}

}  // namespace

// (cv::checkRange would do, but it refuses FLT_MAX.)
std::optional<cv::Point> firstNonFinite(const cv::Mat& image) {
  return firstPixelWhere(image, "image to check for non-finite pixels", [](float v) { return !std::isfinite(v); });
}

std::optional<cv::Point> firstNegative(const cv::Mat& image) {
  return firstPixelWhere(image, "image to check for negative pixels", [](float v) { return v < 0; });
}

double percentile(const cv::Mat& image, double fraction) {
  requireImageType(image, CV_32FC1, "image for a percentile");
  std::vector<float> values(image.begin<float>(), image.end<float>());
  const size_t k = std::min(values.size() - 1,
                            static_cast<size_t>(std::clamp(fraction, 0.0, 1.0) * static_cast<double>(values.size())));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

// libpng's simplified API, not OpenCV's imgcodecs: imgcodecs pulls GDAL and
// about 130 shared libraries into every process that links lfi_core, which
// cost each start of `lfi` and of every test about 0.1 s.
void writePngAtomically(const std::filesystem::path& path, const cv::Mat& image8, Overwrite overwrite) {
  if (image8.empty()) fail(Errc::InvalidArgument, "cannot write '{}': the image is empty", path.string());
  if (image8.type() != CV_8UC1 && image8.type() != CV_8UC3)
    fail(Errc::InvalidArgument, "cannot write '{}' as PNG: pixel type {}, expected 8UC1 (grey) or 8UC3 (BGR)",
         path.string(), cv::typeToString(image8.type()));
  const cv::Mat pixels = image8.isContinuous() ? image8 : image8.clone();
  png_image png{};
  png.version = PNG_IMAGE_VERSION;
  png.width = static_cast<png_uint_32>(pixels.cols);
  png.height = static_cast<png_uint_32>(pixels.rows);
  png.format = pixels.channels() == 1 ? PNG_FORMAT_GRAY : PNG_FORMAT_BGR;
  png_alloc_size_t size = 0;
  const auto encode = [&](void* memory) {
    if (!png_image_write_to_memory(&png, memory, &size, 0, pixels.data, 0, nullptr))
      fail(Errc::Io, "cannot encode '{}' as PNG: {}", path.string(), png.message);
  };
  encode(nullptr);  // the first call only measures
  std::string bytes(size, '\0');
  encode(bytes.data());
  bytes.resize(size);
  writeFileAtomically(path, overwrite, bytes);
}

cv::Mat toneMapForDisplay(const cv::Mat& radiance, double white) {
  requireImageType(radiance, CV_32FC1, "radiance image to tone-map");
  if (white <= 0) {
    white = percentile(radiance, 0.999);
    if (!(white > 0)) white = 1.0;
  }
  cv::Mat out(radiance.size(), CV_8UC1);
  for (int r = 0; r < radiance.rows; ++r) {
    const float* in = radiance.ptr<float>(r);
    uchar* o = out.ptr<uchar>(r);
    for (int c = 0; c < radiance.cols; ++c) {
      const double x = std::clamp(in[c] / white, 0.0, 1.0);
      const double srgb = x <= 0.0031308 ? 12.92 * x : 1.055 * std::pow(x, 1 / 2.4) - 0.055;
      o[c] = static_cast<uchar>(std::lround(255 * srgb));
    }
  }
  return out;
}

}  // namespace lfi
