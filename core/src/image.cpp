#include "lfi/core/image.h"

#include "lfi/core/error.h"

#include <opencv2/imgcodecs.hpp>
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

double percentile(const cv::Mat& image, double fraction) {
  requireImageType(image, CV_32FC1, "image for a percentile");
  std::vector<float> values(image.begin<float>(), image.end<float>());
  const size_t k = std::min(values.size() - 1,
                            static_cast<size_t>(std::clamp(fraction, 0.0, 1.0) * static_cast<double>(values.size())));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

void writePngAtomically(const std::filesystem::path& path, const cv::Mat& image8, Overwrite overwrite) {
  std::vector<uchar> bytes;
  if (!cv::imencode(".png", image8, bytes)) fail(Errc::Io, "cannot encode '{}' as PNG", path.string());
  writeFileAtomically(path, overwrite, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
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
