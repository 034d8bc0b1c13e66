// SPDX-License-Identifier: Apache-2.0
#include "lfi/inspection/defects.h"

#include "defect_regions.h"

#include "lfi/core/error.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <tuple>
#include <vector>

// The row loops of the off pixels' pass are built for several instruction
// sets, chosen at load time, as the tracer's (sim/src/tracer/simd.h, which
// says why the guards): they do the same float operations in every lane, and
// without fused multiply-adds (-ffp-contract=off) every build gives the same bits.
// (Not with clang, the fuzz build's compiler: it takes no target_clones on templates.)
#if defined(__x86_64__) && !defined(__SANITIZE_ADDRESS__) && !defined(__SANITIZE_THREAD__) && !defined(__AVX2__) && \
    !defined(__clang__)
#define LFI_ROW_CLONES __attribute__((target_clones("arch=x86-64-v4", "avx2", "default")))
#else
#define LFI_ROW_CLONES
#endif

namespace lfi {

using detail::addRegions;
using detail::DifferenceRow;
using detail::Run;
using detail::separateGroups;
using detail::windowOf;

namespace {

void checkImage(const cv::Mat& image, const GoldenModel& model) {
  if (image.size() != model.ideal.size() || image.channels() != 1)
    fail(Errc::InvalidArgument, "defects: image {} x {} with {} channel(s) does not match the golden model's {} x {}",
         image.cols, image.rows, image.channels(), model.ideal.cols, model.ideal.rows);
}

void check(const GoldenModel& model, const cv::Mat& mask, const DetectionSettings& s) {
  if (model.ideal.empty() || model.ideal.type() != CV_32FC1 || model.variation.size() != model.ideal.size() ||
      model.variation.type() != CV_32FC1)
    fail(Errc::InvalidArgument, "defects: the golden model is empty or not a pair of float images of one size");
  if (!mask.empty() && (mask.size() != model.ideal.size() || mask.type() != CV_8UC1))
    fail(Errc::InvalidArgument, "defects: mask {} x {} of type {} is not an 8-bit image of the model's {} x {}",
         mask.cols, mask.rows, mask.type(), model.ideal.cols, model.ideal.rows);
  if (!(s.absolute_dn >= 0) || !(s.relative >= 0) || !std::isfinite(s.absolute_dn + s.relative))
    fail(Errc::InvalidArgument, "defects: thresholds a = {} DN, b = {} must be finite and >= 0", s.absolute_dn,
         s.relative);
  if (!(s.smoothing_px >= 0 && s.smoothing_px <= 100))
    fail(Errc::InvalidArgument, "defects: smoothing {} px is outside [0, 100]", s.smoothing_px);
  if (s.closing_px < 0 || s.closing_px > 100 || s.minArea_px < 1)
    fail(Errc::InvalidArgument, "defects: closing {} px must be in [0, 100] and the minimum area {} px at least 1",
         s.closing_px, s.minArea_px);
}

// ---- the off pixels: one banded pass over the frame --------------------------
//
// |smoothed d| > max(a, b · σ) is evaluated band by band of rows:
// each row's difference is smoothed along the row into a ring of 2R + 1 rows,
// then down the columns and compared at once, so the frame and the model are
// read once and no frame-sized image is written. A closing of radius r and
// then the mask see no off pixel farther than 2r (Chebyshev) from the mask:
// only those rows and columns are examined.

// The Gaussian's taps from the centre out (it is symmetric): taps[0] at the centre, taps[i] at ±i.
struct SmoothingKernel {
  std::vector<float> taps{1.f};
  int radius() const { return static_cast<int>(taps.size()) - 1; }
};

SmoothingKernel smoothingKernel(double sigma_px) {
  SmoothingKernel kernel;
  if (!(sigma_px > 0)) return kernel;
  const int size = 2 * static_cast<int>(std::ceil(3 * sigma_px)) + 1, radius = size / 2;
  const cv::Mat k = cv::getGaussianKernel(size, sigma_px, CV_64F);
  kernel.taps.resize(static_cast<size_t>(radius + 1));
  for (int i = 0; i <= radius; ++i) kernel.taps[static_cast<size_t>(i)] = static_cast<float>(k.at<double>(radius + i));
  return kernel;
}

// Σ_p w_x(p)² values(row, p) along each row, w_x the smoothing's weights of
// column x with the pass's reflected border (cv::BORDER_REFLECT): the variance
// of a row's smoothed independent noise. CV_32FC1 in and out.
cv::Mat smoothedVariance(const cv::Mat& values, const std::vector<float>& taps) {
  const int radius = static_cast<int>(taps.size()) - 1, width = values.cols, n = 2 * radius + 1;
  // Column x's kernel as n (pixel, squared weight) pairs; a pixel met twice has one pair with the taps'
  // sum and one of weight 0.
  std::vector<int> pixel(static_cast<size_t>(width) * static_cast<size_t>(n), 0);
  std::vector<float> weight2(pixel.size(), 0.f);
  for (int x = 0; x < width; ++x) {
    int* px = pixel.data() + static_cast<std::ptrdiff_t>(x) * n;
    std::vector<double> w(static_cast<size_t>(n), 0.0);
    for (int i = -radius; i <= radius; ++i) {
      const int p = cv::borderInterpolate(x + i, width, cv::BORDER_REFLECT);
      const int slot = static_cast<int>(std::find(px, px + (i + radius), p) - px);  // an earlier tap's pixel?
      px[slot] = p;
      w[static_cast<size_t>(slot)] += taps[static_cast<size_t>(std::abs(i))];
    }
    for (int k = 0; k < n; ++k)
      weight2[static_cast<size_t>(x) * static_cast<size_t>(n) + static_cast<size_t>(k)] =
          static_cast<float>(w[static_cast<size_t>(k)] * w[static_cast<size_t>(k)]);
  }
  cv::Mat out(values.size(), CV_32FC1);
  cv::parallel_for_(cv::Range(0, values.rows), [&](const cv::Range& rows) {
    for (int row = rows.start; row < rows.end; ++row) {
      const float* v = values.ptr<float>(row);
      float* o = out.ptr<float>(row);
      for (int x = 0; x < width; ++x) {
        const size_t at = static_cast<size_t>(x) * static_cast<size_t>(n);
        double sum = 0;
        for (int k = 0; k < n; ++k) sum += weight2[at + static_cast<size_t>(k)] * v[pixel[at + static_cast<size_t>(k)]];
        o[x] = static_cast<float>(sum);
      }
    }
  });
  return out;
}

struct OffPixelSettings {
  SmoothingKernel kernel;
  float threshold_dn = 0;  // a
  float relative = 0;      // b: the threshold in units of σ
  int reach_px = 0;        // how far from the mask an off pixel can still matter
};

// Columns [begin, end) of a row; none when begin >= end.
struct Span {
  int begin = 0, end = 0;
  bool empty() const { return begin >= end; }
};

int firstNonzero(const std::uint8_t* p, int n) {
  int i = 0;
  for (std::uint64_t word = 0; i + 8 <= n; i += 8) {
    std::memcpy(&word, p + i, 8);
    if (word != 0) break;
  }
  for (; i < n; ++i)
    if (p[i] != 0) return i;
  return n;
}

int lastNonzero(const std::uint8_t* p, int n) {  // -1: none
  int i = n;
  for (std::uint64_t word = 0; i >= 8; i -= 8) {
    std::memcpy(&word, p + i - 8, 8);
    if (word != 0) break;
  }
  for (; i > 0; --i)
    if (p[i - 1] != 0) return i - 1;
  return -1;
}

// A few rows ahead, the lines a row's loop will read: each row starts a new
// stream (several pages on), which the hardware's prefetchers pick up late.
constexpr int kRowsAhead = 4;
void prefetch(const void* begin, size_t bytes) {
  const char* p = static_cast<const char*>(begin);
  for (size_t offset = 0; offset < bytes; offset += 64) __builtin_prefetch(p + offset);
}

// DifferenceRow for one pixel type.
template <typename Pixel>
LFI_ROW_CLONES void differenceRow(const void* imageRow, const float* __restrict ideal, int begin, int end,
                                  float* __restrict out) {
  const Pixel* __restrict image = static_cast<const Pixel*>(imageRow);
  for (int c = begin; c < end; ++c) out[c - begin] = static_cast<float>(image[c]) - ideal[c];
}

// h[j] = Σ_i taps[|i|] d[j + i], i in [-R, R]; d is valid on [-R, n + R).
template <int R>
LFI_ROW_CLONES void horizontal(const float* __restrict d, const float* taps, int n, float* __restrict h) {
  float k[R + 1];
  for (int i = 0; i <= R; ++i) k[i] = taps[i];
  for (int j = 0; j < n; ++j) {
    float acc = k[0] * d[j];
    for (int i = 1; i <= R; ++i) acc += k[i] * (d[j - i] + d[j + i]);
    h[j] = acc;
  }
}

LFI_ROW_CLONES void horizontalAnyRadius(const float* __restrict d, const float* taps, int radius, int n,
                                        float* __restrict h) {
  for (int j = 0; j < n; ++j) h[j] = taps[0] * d[j];
  for (int i = 1; i <= radius; ++i)
    for (int j = 0; j < n; ++j) h[j] += taps[i] * (d[j - i] + d[j + i]);
}

// s[j] = Σ_i taps[|i|] rows[R + i][j], and whether any |s[j]| > max(a, relative · σ[j]).
template <int R>
LFI_ROW_CLONES bool vertical(const float* const* rows, const float* taps, const float* __restrict sigma, float relative,
                             float a, int n, float* __restrict s) {
  float k[R + 1];
  const float* __restrict r[2 * R + 1];
  for (int i = 0; i <= R; ++i) k[i] = taps[i];
  for (int i = 0; i <= 2 * R; ++i) r[i] = rows[i];
  int any = 0;
  for (int j = 0; j < n; ++j) {
    float acc = k[0] * r[R][j];
    for (int i = 1; i <= R; ++i) acc += k[i] * (r[R - i][j] + r[R + i][j]);
    s[j] = acc;
    any |= std::abs(acc) > std::max(a, relative * sigma[j]);
  }
  return any != 0;
}

LFI_ROW_CLONES bool verticalAnyRadius(const float* const* rows, const float* taps, int radius,
                                      const float* __restrict sigma, float relative, float a, int n,
                                      float* __restrict s) {
  for (int j = 0; j < n; ++j) s[j] = taps[0] * rows[radius][j];
  for (int i = 1; i <= radius; ++i) {
    const float* __restrict up = rows[radius - i];
    const float* __restrict down = rows[radius + i];
    for (int j = 0; j < n; ++j) s[j] += taps[i] * (up[j] + down[j]);
  }
  int any = 0;
  for (int j = 0; j < n; ++j) any |= std::abs(s[j]) > std::max(a, relative * sigma[j]);
  return any != 0;
}

struct Filters {
  void (*horizontal)(const float*, const float*, int, float*) = nullptr;  // null: horizontalAnyRadius
  bool (*vertical)(const float* const*, const float*, const float*, float, float, int, float*) = nullptr;
};

template <int R>
Filters filtersOf() {
  return {&horizontal<R>, &vertical<R>};
}

Filters filtersFor(int radius) {
  switch (radius) {
    case 0:
      return filtersOf<0>();
    case 1:
      return filtersOf<1>();
    case 2:
      return filtersOf<2>();
    case 3:
      return filtersOf<3>();
    case 4:
      return filtersOf<4>();
    case 5:
      return filtersOf<5>();
    case 6:
      return filtersOf<6>();
    default:
      return {};
  }
}

// One band of rows [y0, y1): where in each row an off pixel can matter, then
// the difference of each row the band's smoothing needs, smoothed along the
// row into a ring of 2R + 1 rows, then down the columns and compared with the
// threshold, row by row.
class Band {
 public:
  Band(const cv::Mat& image, DifferenceRow difference, const GoldenModel& model, const cv::Mat& mask,
       const OffPixelSettings& settings)
      : image_(image),
        difference_(difference),
        model_(model),
        mask_(mask),
        s_(settings),
        taps_(settings.kernel.taps.data()),
        radius_(settings.kernel.radius()),
        filters_(filtersFor(settings.kernel.radius())) {}

  void run(int y0, int y1, std::vector<Run>& off) {
    findSpans(y0, y1);
    int c0 = INT_MAX, c1 = INT_MIN;
    for (const Span& span : spans_) {
      if (span.empty()) continue;
      c0 = std::min(c0, span.begin);
      c1 = std::max(c1, span.end);
    }
    if (c0 >= c1) return;
    c0_ = c0, c1_ = c1;
    const int n = c1 - c0, window = 2 * radius_ + 1;
    d_.resize(static_cast<size_t>(n + 2 * radius_));
    ring_.resize(static_cast<size_t>(window) * static_cast<size_t>(n));
    sRow_.resize(static_cast<size_t>(n));
    rows_.resize(static_cast<size_t>(window));
    first_ = y0 - radius_;
    for (int v = y0 - radius_; v < y0 + radius_; ++v) smoothRow(v);
    for (int y = y0; y < y1; ++y) {
      smoothRow(y + radius_);
      const Span& span = spans_[static_cast<size_t>(y - y0)];
      if (y + kRowsAhead < y1) {
        const Span& ahead = spans_[static_cast<size_t>(y + kRowsAhead - y0)];
        if (!ahead.empty())
          prefetch(model_.variation.ptr<float>(y + kRowsAhead) + ahead.begin,
                   sizeof(float) * static_cast<size_t>(ahead.end - ahead.begin));
      }
      if (span.empty()) continue;
      const int offset = span.begin - c0, count = span.end - span.begin;
      for (int i = 0; i < window; ++i) rows_[static_cast<size_t>(i)] = slot(y - radius_ + i) + offset;
      const float* sigma = model_.variation.ptr<float>(y) + span.begin;
      const bool any = filters_.vertical ? filters_.vertical(rows_.data(), taps_, sigma, s_.relative, s_.threshold_dn,
                                                             count, sRow_.data())
                                         : verticalAnyRadius(rows_.data(), taps_, radius_, sigma, s_.relative,
                                                             s_.threshold_dn, count, sRow_.data());
      if (!any) continue;
      const auto isOff = [&](int j) {
        return std::abs(sRow_[static_cast<size_t>(j)]) > std::max(s_.threshold_dn, s_.relative * sigma[j]);
      };
      for (int j = 0; j < count; ++j) {
        if (!isOff(j)) continue;
        const int begin = j;
        while (j < count && isOff(j)) ++j;
        off.push_back({y, span.begin + begin, span.begin + j});
      }
    }
  }

 private:
  // spans_[y - y0]: the hull of the mask's nonzero columns over the rows within reach, widened by reach.
  void findSpans(int y0, int y1) {
    const int width = image_.cols, height = image_.rows, reach = s_.reach_px;
    spans_.assign(static_cast<size_t>(y1 - y0), Span{0, width});
    if (mask_.empty()) return;
    const int r0 = std::max(0, y0 - reach), r1 = std::min(height, y1 + reach);
    extents_.assign(static_cast<size_t>(r1 - r0), Span{});
    const size_t ends = std::min<size_t>(static_cast<size_t>(width), 640);
    for (int row = r0; row < r1; ++row) {
      if (row + kRowsAhead < r1) {
        const std::uint8_t* ahead = mask_.ptr<std::uint8_t>(row + kRowsAhead);
        prefetch(ahead, ends);
        prefetch(ahead + width - ends, ends);
      }
      const std::uint8_t* m = mask_.ptr<std::uint8_t>(row);
      const int first = firstNonzero(m, width);
      if (first < width) extents_[static_cast<size_t>(row - r0)] = {first, lastNonzero(m, width) + 1};
    }
    for (int y = y0; y < y1; ++y) {
      int begin = INT_MAX, end = INT_MIN;
      for (int r = std::max(r0, y - reach); r < std::min(r1, y + reach + 1); ++r) {
        const Span& e = extents_[static_cast<size_t>(r - r0)];
        if (e.empty()) continue;
        begin = std::min(begin, e.begin);
        end = std::max(end, e.end);
      }
      spans_[static_cast<size_t>(y - y0)] =
          begin < end ? Span{std::max(0, begin - reach), std::min(width, end + reach)} : Span{};
    }
  }

  float* slot(int v) {
    return ring_.data() + static_cast<size_t>((v - first_) % (2 * radius_ + 1)) * static_cast<size_t>(c1_ - c0_);
  }

  // The row v (reflected into the image, as cv::BORDER_REFLECT), smoothed along itself, into its slot.
  void smoothRow(int v) {
    const int width = image_.cols, height = image_.rows, r = radius_;
    const int begin = std::max(0, c0_ - r), end = std::min(width, c1_ + r);
    if (v + kRowsAhead >= 0 && v + kRowsAhead < height) {
      prefetch(model_.ideal.ptr<float>(v + kRowsAhead) + begin, sizeof(float) * static_cast<size_t>(end - begin));
      prefetch(image_.ptr(v + kRowsAhead) + image_.elemSize() * static_cast<size_t>(begin),
               image_.elemSize() * static_cast<size_t>(end - begin));
    }
    const int row = cv::borderInterpolate(v, height, cv::BORDER_REFLECT);
    const void* image = image_.ptr(row);
    const float* ideal = model_.ideal.ptr<float>(row);
    // d_[j] is column c0 - R + j; the columns beyond the image are reflected ones.
    float* d = d_.data();
    difference_(image, ideal, begin, end, d + (begin - (c0_ - r)));
    for (int c = c0_ - r; c < begin; ++c) {
      const int x = cv::borderInterpolate(c, width, cv::BORDER_REFLECT);
      difference_(image, ideal, x, x + 1, d + (c - (c0_ - r)));
    }
    for (int c = end; c < c1_ + r; ++c) {
      const int x = cv::borderInterpolate(c, width, cv::BORDER_REFLECT);
      difference_(image, ideal, x, x + 1, d + (c - (c0_ - r)));
    }
    if (filters_.horizontal)
      filters_.horizontal(d + r, taps_, c1_ - c0_, slot(v));
    else
      horizontalAnyRadius(d + r, taps_, r, c1_ - c0_, slot(v));
  }

  const cv::Mat& image_;
  DifferenceRow difference_;
  const GoldenModel& model_;
  const cv::Mat& mask_;
  const OffPixelSettings& s_;
  const float* taps_;
  int radius_;
  Filters filters_;
  int c0_ = 0, c1_ = 0, first_ = 0;
  std::vector<Span> spans_, extents_;
  std::vector<float> d_, ring_, sRow_;
  std::vector<const float*> rows_;
};

DifferenceRow differenceRowFor(int depth) {
  switch (depth) {
    case CV_8U:
      return &differenceRow<std::uint8_t>;
    case CV_16U:
      return &differenceRow<std::uint16_t>;
    default:
      return &differenceRow<float>;
  }
}

// The image as the pass reads it: 8-bit, 16-bit and float as they are, other depths converted to float (the
// difference's definition).
cv::Mat pixelsForPass(const cv::Mat& image) {
  if (image.depth() == CV_8U || image.depth() == CV_16U || image.depth() == CV_32F) return image;
  cv::Mat values;
  image.convertTo(values, CV_32F);
  return values;
}

// The off pixels as runs in raster order: bands of rows on OpenCV's threads.
std::vector<Run> findOffRuns(const cv::Mat& values, const GoldenModel& model, const cv::Mat& mask,
                             const OffPixelSettings& settings) {
  // Bands tall enough that the 2R rows a band's smoothing reads beyond its own, and the 2r rows of mask its
  // spans do, stay a small share.
  const int bandRows = std::max({64, 4 * settings.kernel.radius(), 2 * settings.reach_px});
  const int bands = (values.rows + bandRows - 1) / bandRows;
  std::vector<std::vector<Run>> off(static_cast<size_t>(bands));
  cv::parallel_for_(
      cv::Range(0, bands),
      [&](const cv::Range& range) {
        Band band(values, differenceRowFor(values.depth()), model, mask, settings);
        for (int b = range.start; b < range.end; ++b)
          band.run(b * bandRows, std::min(values.rows, (b + 1) * bandRows), off[static_cast<size_t>(b)]);
      },
      bands);
  std::vector<Run> all;
  for (const auto& band : off) all.insert(all.end(), band.begin(), band.end());
  return all;
}

}  // namespace

DefectFinder::DefectFinder(const GoldenModel& model, const cv::Mat& mask, const DetectionSettings& settings)
    : mask_(mask), settings_(settings) {
  check(model, mask, settings);
  threshold_.ideal = model.ideal;
  threshold_.images = model.images;
  // A good image differs from the ideal, the mean of n such images, by its own noise and the ideal's:
  // variance variation² (1 + 1/n).
  const double ofIdeal = model.images > 0 ? 1 + 1.0 / model.images : 1;
  cv::Mat variance = model.variation.mul(model.variation) * ofIdeal;
  if (settings.smoothing_px > 0) {
    // The smoothed difference of independent pixels has the variance Σ_p W(x, p)² variance(p), W the
    // pass's separable smoothing: along each axis the kernel's taps, a pixel that the reflected border
    // brings into the kernel twice weighted by the two taps' sum (so near a border this is not a filter).
    const SmoothingKernel kernel = smoothingKernel(settings.smoothing_px);
    variance = smoothedVariance(variance, kernel.taps);          // along the rows
    variance = smoothedVariance(variance.t(), kernel.taps).t();  // down the columns
  }
  cv::sqrt(variance, threshold_.variation);
}

std::vector<Defect> findDefects(const cv::Mat& image, const GoldenModel& model, const cv::Mat& mask,
                                const DetectionSettings& settings) {
  return DefectFinder(model, mask, settings).find(image);
}

std::vector<Defect> DefectFinder::find(const cv::Mat& image) const {
  checkImage(image, threshold_);
  const GoldenModel& model = threshold_;
  const cv::Mat& mask = mask_;
  const DetectionSettings& settings = settings_;
  OffPixelSettings off{.kernel = smoothingKernel(settings.smoothing_px)};
  off.threshold_dn = static_cast<float>(settings.absolute_dn);
  off.relative = static_cast<float>(settings.relative);  // (σ holds the smoothing's effect on the noise)
  off.reach_px = 2 * settings.closing_px;
  const cv::Mat values = pixelsForPass(image);
  const std::vector<Run> runs = findOffRuns(values, model, mask, off);
  std::vector<Defect> defects;
  if (runs.empty()) return defects;  // a good part: nothing to close or label
  std::vector<std::vector<Run>> groups = separateGroups(runs, image.size(), settings.closing_px);
  // Groups whose windows together cover more than one window around all of them (noise everywhere, a wrong
  // part) are labelled in that one window: a frame's worth at most.
  double covered = 0;
  for (const auto& group : groups) covered += windowOf(group, image.size(), settings.closing_px).area();
  if (groups.size() > 1 && covered > windowOf(runs, image.size(), settings.closing_px).area()) groups.assign(1, runs);
  if (groups.size() == 1) {
    addRegions(groups[0], values, differenceRowFor(values.depth()), model, mask, settings, defects);
  } else {  // several small windows: one at a time on each thread (OpenCV's own calls inside run serially)
    std::vector<std::vector<Defect>> found(groups.size());
    cv::parallel_for_(cv::Range(0, static_cast<int>(groups.size())), [&](const cv::Range& range) {
      for (int g = range.start; g < range.end; ++g)
        addRegions(groups[static_cast<size_t>(g)], values, differenceRowFor(values.depth()), model, mask, settings,
                   found[static_cast<size_t>(g)]);
    });
    for (const auto& f : found) defects.insert(defects.end(), f.begin(), f.end());
  }
  std::sort(defects.begin(), defects.end(), [](const Defect& a, const Defect& b) {
    if (a.area_px != b.area_px) return a.area_px > b.area_px;
    return std::tuple(a.bounds_px.y, a.bounds_px.x, a.centroid_px.y, a.centroid_px.x) <
           std::tuple(b.bounds_px.y, b.bounds_px.x, b.centroid_px.y, b.centroid_px.x);
  });
  return defects;
}

}  // namespace lfi
