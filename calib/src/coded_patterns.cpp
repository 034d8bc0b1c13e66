// SPDX-License-Identifier: Apache-2.0
#include "lfi/calib/coded_patterns.h"

#include "lfi/core/error.h"

#include <opencv2/structured_light.hpp>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>
#include <vector>

namespace lfi::calib {

namespace {

// ⌈log2 n⌉ for n ≥ 1, exactly (OpenCV computes it in floating point; the two agree over 1 .. kMaxPanelSide).
int bitsFor(int n) {
  return std::bit_width(static_cast<unsigned>(n - 1));
}

void checkSide(const char* what, const char* name, int side) {
  if (side < 1 || side > GrayCodeLayout::kMaxPanelSide)
    fail(Errc::InvalidArgument, "{}: panel {} {} is outside 1 .. {}", what, name, side, GrayCodeLayout::kMaxPanelSide);
}

// Camera rows decoded together: each frame is read as one run of this many rows per bit, and the codes of
// the rows' pixels stay in the core's cache between the bits.
constexpr int kTileRows = 8;

// The per-pixel accumulators of a tile: Gray codes so far (most significant bit first) and the smallest
// |pattern − inverse| so far. Panel sides ≤ 65536 keep codes within 16 bits, and CV_16U contrasts too.
// With two sources per axis (DecodeSettings::secondShare > 0), per axis: the bits read as split (below
// splitBelow) and the smallest and largest split contrast, and the smallest contrast of the other bits.
struct TileState {
  std::vector<std::uint16_t> column, row, minContrast;
  std::vector<std::uint16_t> splitBelow;
  std::vector<std::uint16_t> split[2], minSplit[2], maxSplit[2], minClear;
  TileState(size_t pixels, bool twoSources) : column(pixels), row(pixels), minContrast(pixels) {
    if (!twoSources) return;
    splitBelow.resize(pixels);
    minClear.resize(pixels);
    for (int axis = 0; axis < 2; ++axis) {
      split[axis].resize(pixels);
      minSplit[axis].resize(pixels);
      maxSplit[axis].resize(pixels);
    }
  }
};

// One bit of one camera row: a plain loop over pixels that the compiler vectorises.
template <typename T>
void accumulateBit(const T* pattern, const T* inverse, std::uint16_t* code, std::uint16_t* minContrast, int n) {
  for (int i = 0; i < n; ++i) {
    const std::uint16_t a = pattern[i], b = inverse[i];
    const std::uint16_t contrast = static_cast<std::uint16_t>(std::max(a, b) - std::min(a, b));
    code[i] = static_cast<std::uint16_t>((code[i] << 1) | (a > b ? 1 : 0));
    minContrast[i] = std::min(minContrast[i], contrast);
  }
}

// The same with the split bits kept apart; the arrays do not overlap.
template <typename T>
void accumulateSplitBit(const T* __restrict pattern, const T* __restrict inverse,
                        const std::uint16_t* __restrict splitBelow, std::uint16_t* __restrict code,
                        std::uint16_t* __restrict split, std::uint16_t* __restrict minSplit,
                        std::uint16_t* __restrict maxSplit, std::uint16_t* __restrict minClear, int n) {
  for (int i = 0; i < n; ++i) {
    // (Values, not std::min's references, and masks, all ones where the bit is split: no branch in the loop.)
    const std::uint16_t a = pattern[i], b = inverse[i];
    const std::uint16_t contrast = static_cast<std::uint16_t>(a > b ? a - b : b - a);
    const std::uint16_t splitMask = contrast < splitBelow[i] ? 0xffff : 0;
    const auto least = [](std::uint16_t x, std::uint16_t y) { return x < y ? x : y; };
    const auto most = [](std::uint16_t x, std::uint16_t y) { return x > y ? x : y; };
    code[i] = static_cast<std::uint16_t>((code[i] << 1) | (a > b ? 1 : 0));
    split[i] = static_cast<std::uint16_t>((split[i] << 1) | (splitMask & 1));
    minSplit[i] = least(minSplit[i], static_cast<std::uint16_t>(contrast | ~splitMask));
    maxSplit[i] = most(maxSplit[i], static_cast<std::uint16_t>(contrast & splitMask));
    minClear[i] = least(minClear[i], static_cast<std::uint16_t>(contrast | splitMask));
  }
}

std::uint16_t grayToBinary(std::uint16_t g) {
  g ^= static_cast<std::uint16_t>(g >> 1);
  g ^= static_cast<std::uint16_t>(g >> 2);
  g ^= static_cast<std::uint16_t>(g >> 4);
  g ^= static_cast<std::uint16_t>(g >> 8);
  return g;
}

struct Counts {
  int lit = 0, decoded = 0;
};

// One axis of a pixel with two sources allowed: the panel column (row) of the brighter source, the other's or
// −1, the brighter one's share of the light, and the smallest contrast of a bit the reading trusts (0xffff: none).
// Two sources differ in exactly the split bits, and each split bit's contrast is the difference of their
// shares: with two or more split bits, contrasts that disagree mean more than two sources (read as the
// brightest alone, every bit trusted as with one source), and each must be readable for its sign to tell which
// code is the brighter one.
struct AxisSources {
  int first = -1, second = -1;
  float share = 1;
  int weakest = 0xffff;
};

bool decodeAxis(std::uint16_t code, std::uint16_t split, int minSplit, int maxSplit, int range, int size,
                const DecodeSettings& s, AxisSources& out) {
  const int splitBits = std::popcount(static_cast<unsigned>(split));
  const double readable = std::max<double>(s.minContrast_dn, s.minContrastFraction * range);
  out.first = grayToBinary(code);
  if (out.first >= size) return false;
  if (splitBits == 0) return true;
  if (splitBits >= 2 && minSplit < readable) return false;
  if (splitBits >= 2 && maxSplit - minSplit > readable) {  // more than two: the brightest alone
    out.weakest = minSplit;
    return true;
  }
  out.second = grayToBinary(static_cast<std::uint16_t>(code ^ split));
  if (out.second >= size) return false;
  out.share = static_cast<float>(0.5 * (1 + 0.5 * (minSplit + maxSplit) / range));
  return true;
}

// Decodes camera rows [row0, row1): every frame is read once, a tile of rows at a time.
template <typename T>
Counts decodeRows(const std::vector<cv::Mat>& frames, const cv::Mat& white, const cv::Mat& black,
                  const GrayCodeLayout& layout, const DecodeSettings& s, PanelCorrespondence& out, int row0, int row1) {
  const int width = white.cols;
  const int bits = layout.columnBits + layout.rowBits;
  const bool twoSources = s.secondShare > 0;
  TileState state(static_cast<size_t>(kTileRows) * static_cast<size_t>(width), twoSources);
  Counts counts;
  for (int tile0 = row0; tile0 < row1; tile0 += kTileRows) {
    const int tile1 = std::min(tile0 + kTileRows, row1);
    std::fill(state.column.begin(), state.column.end(), 0);
    std::fill(state.row.begin(), state.row.end(), 0);
    std::fill(state.minContrast.begin(), state.minContrast.end(), std::uint16_t{0xffff});
    if (twoSources) {
      for (int axis = 0; axis < 2; ++axis) {
        std::fill(state.split[axis].begin(), state.split[axis].end(), 0);
        std::fill(state.minSplit[axis].begin(), state.minSplit[axis].end(), std::uint16_t{0xffff});
        std::fill(state.maxSplit[axis].begin(), state.maxSplit[axis].end(), 0);
      }
      std::fill(state.minClear.begin(), state.minClear.end(), std::uint16_t{0xffff});
      // A bit is split when its contrast is below (1 − 2·secondShare) of the pixel's white − black.
      for (int v = tile0; v < tile1; ++v) {
        const T* w = white.ptr<T>(v);
        const T* b = black.ptr<T>(v);
        for (int u = 0; u < width; ++u) {
          const double range = std::max(0, static_cast<int>(w[u]) - static_cast<int>(b[u]));
          state.splitBelow[static_cast<size_t>(v - tile0) * static_cast<size_t>(width) + static_cast<size_t>(u)] =
              static_cast<std::uint16_t>(std::ceil((1 - 2 * s.secondShare) * range));
        }
      }
    }
    for (int bit = 0; bit < bits; ++bit) {
      const bool isColumn = bit < layout.columnBits;
      const int axis = isColumn ? 0 : 1;
      const int index = isColumn ? layout.columnPattern(bit) : layout.rowPattern(bit - layout.columnBits);
      std::uint16_t* codes = isColumn ? state.column.data() : state.row.data();
      const cv::Mat& pattern = frames[static_cast<size_t>(index)];
      const cv::Mat& inverse = frames[static_cast<size_t>(index) + 1];
      for (int v = tile0; v < tile1; ++v) {
        const size_t at = static_cast<size_t>(v - tile0) * static_cast<size_t>(width);
        if (twoSources)
          accumulateSplitBit(pattern.ptr<T>(v), inverse.ptr<T>(v), state.splitBelow.data() + at, codes + at,
                             state.split[axis].data() + at, state.minSplit[axis].data() + at,
                             state.maxSplit[axis].data() + at, state.minClear.data() + at, width);
        else
          accumulateBit(pattern.ptr<T>(v), inverse.ptr<T>(v), codes + at, state.minContrast.data() + at, width);
      }
    }
    for (int v = tile0; v < tile1; ++v) {
      const size_t at = static_cast<size_t>(v - tile0) * static_cast<size_t>(width);
      const T* w = white.ptr<T>(v);
      const T* b = black.ptr<T>(v);
      auto* panel = out.panel.ptr<cv::Vec2i>(v);
      auto* second = twoSources ? out.second.ptr<cv::Vec2i>(v) : nullptr;
      auto* share = twoSources ? out.share.ptr<cv::Vec2f>(v) : nullptr;
      auto* confidence = out.confidence.ptr<float>(v);
      for (int u = 0; u < width; ++u) {
        const int range = static_cast<int>(w[u]) - static_cast<int>(b[u]);
        panel[u] = cv::Vec2i(-1, -1);
        confidence[u] = 0;
        if (twoSources) {
          second[u] = cv::Vec2i(-1, -1);
          share[u] = cv::Vec2f(1, 1);
        }
        if (range < s.minLit_dn) continue;
        ++counts.lit;
        if (twoSources) {
          const size_t k = at + static_cast<size_t>(u);
          AxisSources x, y;
          if (!decodeAxis(state.column[k], state.split[0][k], state.minSplit[0][k], state.maxSplit[0][k], range,
                          layout.panelWidth, s, x) ||
              !decodeAxis(state.row[k], state.split[1][k], state.minSplit[1][k], state.maxSplit[1][k], range,
                          layout.panelHeight, s, y))
            continue;
          const int clear = std::min({static_cast<int>(state.minClear[k]), x.weakest, y.weakest, range});
          if (clear < s.minContrast_dn) continue;
          panel[u] = cv::Vec2i(x.first, y.first);
          second[u] = cv::Vec2i(x.second, y.second);
          share[u] = cv::Vec2f(x.share, y.share);
          confidence[u] = static_cast<float>(clear) / static_cast<float>(range);
          ++counts.decoded;
          continue;
        }
        const int contrast = bits == 0 ? range : state.minContrast[at + static_cast<size_t>(u)];
        if (contrast < s.minContrast_dn || contrast < s.minContrastFraction * range) continue;
        const int x = grayToBinary(state.column[at + static_cast<size_t>(u)]);
        const int y = grayToBinary(state.row[at + static_cast<size_t>(u)]);
        if (x >= layout.panelWidth || y >= layout.panelHeight) continue;
        panel[u] = cv::Vec2i(x, y);
        confidence[u] = static_cast<float>(contrast) / static_cast<float>(range);
        ++counts.decoded;
      }
    }
  }
  return counts;
}

void checkInputs(const std::vector<cv::Mat>& frames, const cv::Mat& white, const cv::Mat& black,
                 const GrayCodeLayout& layout, const DecodeSettings& s) {
  constexpr const char* what = "decodeGrayCode";
  checkSide(what, "width", layout.panelWidth);
  checkSide(what, "height", layout.panelHeight);
  if (layout.columnBits != bitsFor(layout.panelWidth) || layout.rowBits != bitsFor(layout.panelHeight))
    fail(Errc::InvalidArgument,
         "{}: the layout's {} column and {} row bits do not fit its {} x {} panel (it takes {} and {})", what,
         layout.columnBits, layout.rowBits, layout.panelWidth, layout.panelHeight, bitsFor(layout.panelWidth),
         bitsFor(layout.panelHeight));
  if (s.minLit_dn < 1 || s.minLit_dn > 65535)
    fail(Errc::InvalidArgument, "{}: settings.minLit_dn = {} is outside 1 .. 65535", what, s.minLit_dn);
  if (s.minContrast_dn < 1 || s.minContrast_dn > 65535)
    fail(Errc::InvalidArgument, "{}: settings.minContrast_dn = {} is outside 1 .. 65535", what, s.minContrast_dn);
  if (!(s.minContrastFraction >= 0 && s.minContrastFraction <= 1))
    fail(Errc::InvalidArgument, "{}: settings.minContrastFraction = {} is outside 0 .. 1", what, s.minContrastFraction);
  if (!(s.secondShare >= 0 && s.secondShare < 0.5))
    fail(Errc::InvalidArgument, "{}: settings.secondShare = {} is outside [0, 0.5)", what, s.secondShare);
  if (static_cast<int>(frames.size()) != layout.patternCount())
    fail(Errc::InvalidArgument,
         "{}: {} pattern frames for a {} x {} panel's set, which has {} patterns ({} column and {} row bits, each "
         "with its inverse; white and black are passed apart)",
         what, frames.size(), layout.panelWidth, layout.panelHeight, layout.patternCount(), layout.columnBits,
         layout.rowBits);
  if (white.empty()) fail(Errc::InvalidArgument, "{}: the white frame is empty", what);
  if (white.type() != CV_8UC1 && white.type() != CV_16UC1)
    fail(Errc::InvalidArgument, "{}: the white frame is of type {}, not CV_8UC1 or CV_16UC1", what,
         cv::typeToString(white.type()));
  auto same = [&](const cv::Mat& frame, const std::string& name) {
    if (frame.type() != white.type())
      fail(Errc::InvalidArgument, "{}: {} is of type {}, the white frame of type {}", what, name,
           cv::typeToString(frame.type()), cv::typeToString(white.type()));
    if (frame.size() != white.size())
      fail(Errc::InvalidArgument, "{}: {} is {} x {} pixels, the white frame {} x {}", what, name, frame.cols,
           frame.rows, white.cols, white.rows);
  };
  same(black, "the black frame");
  for (size_t i = 0; i < frames.size(); ++i) same(frames[i], "pattern frame " + std::to_string(i));
}

}  // namespace

GrayCodeLayout GrayCodeLayout::forPanel(int panelWidth, int panelHeight) {
  checkSide("GrayCodeLayout", "width", panelWidth);
  checkSide("GrayCodeLayout", "height", panelHeight);
  return {.panelWidth = panelWidth,
          .panelHeight = panelHeight,
          .columnBits = bitsFor(panelWidth),
          .rowBits = bitsFor(panelHeight)};
}

CodedPatternSet grayCodePatterns(int panelWidth, int panelHeight) {
  checkSide("grayCodePatterns", "width", panelWidth);
  checkSide("grayCodePatterns", "height", panelHeight);
  CodedPatternSet set;
  set.layout = GrayCodeLayout::forPanel(panelWidth, panelHeight);
  const cv::Ptr<cv::structured_light::GrayCodePattern> gray =
      cv::structured_light::GrayCodePattern::create(panelWidth, panelHeight);
  gray->generate(set.patterns);
  if (static_cast<int>(set.patterns.size()) != set.layout.patternCount())
    fail(Errc::InvalidArgument, "grayCodePatterns: OpenCV made {} patterns for a {} x {} panel, which takes {}",
         set.patterns.size(), panelWidth, panelHeight, set.layout.patternCount());
  gray->getImagesForShadowMasks(set.black, set.white);
  return set;
}

PanelCorrespondence decodeGrayCode(const std::vector<cv::Mat>& frames, const cv::Mat& white, const cv::Mat& black,
                                   const GrayCodeLayout& layout, const DecodeSettings& settings) {
  checkInputs(frames, white, black, layout, settings);
  PanelCorrespondence out;
  out.panel.create(white.size(), CV_32SC2);
  if (settings.secondShare > 0) {
    out.second.create(white.size(), CV_32SC2);
    out.share.create(white.size(), CV_32FC2);
  }
  out.confidence.create(white.size(), CV_32FC1);
  std::atomic<int> lit{0}, decoded{0};
  const int rows = white.rows;
  cv::parallel_for_(
      cv::Range(0, rows),
      [&](const cv::Range& band) {
        const Counts c =
            white.depth() == CV_8U
                ? decodeRows<std::uint8_t>(frames, white, black, layout, settings, out, band.start, band.end)
                : decodeRows<std::uint16_t>(frames, white, black, layout, settings, out, band.start, band.end);
        lit += c.lit;
        decoded += c.decoded;
      },
      std::ceil(static_cast<double>(rows) / kTileRows));
  out.lit = lit;
  out.decoded = decoded;
  return out;
}

}  // namespace lfi::calib
