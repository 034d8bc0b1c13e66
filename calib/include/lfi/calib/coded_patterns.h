// SPDX-License-Identifier: Apache-2.0
#pragma once
// Binary Gray code patterns for the display's panel and their decoding per
// camera pixel: which panel pixel's light reaches each camera pixel. This is
// how a bench without a light field sensor measures its correspondences
// through its own display and camera.
//
// Frames: a panel pixel (x, y) is column x (right) and row y (down) of the
// display's panel image, the image Display::show takes; it covers
// [x, x + 1) × [y, y + 1) in panel pixel units. A camera pixel (u, v) is
// column u, row v of the camera's frame, row 0 at the top.
//
// Patterns: OpenCV's cv::structured_light::GrayCodePattern makes them, in its
// order (checked by the tests):
//   - the column patterns first, then the row patterns;
//   - within each axis the most significant bit first;
//   - each pattern immediately followed by its inverse.
// Pattern 2k (k = 0 .. columnBits - 1) lights (255) the panel columns x whose
// Gray code gray(x) = x ^ (x >> 1) has bit columnBits - 1 - k set, and is 0
// elsewhere; pattern 2k + 1 is its inverse. Pattern 2·columnBits + 2k and the
// one after it do the same for rows. A column pattern is constant down a
// column, a row pattern along a row. Counts for a W × H panel:
// columnBits = ⌈log2 W⌉, rowBits = ⌈log2 H⌉ (0 for a single column or row),
// 2·(columnBits + rowBits) patterns, plus all-white and all-black: frames =
// 2·(columnBits + rowBits) + 2 (42 for 800 × 800, 50 for 3840 × 2160).
//
// Decoding, per camera pixel, in the camera's digital numbers (DN, of CV_8U or
// CV_16U frames): the pixel sees the panel (is lit) when white − black ≥
// minLit_dn. Each bit is 1 when the pattern's frame is brighter than its
// inverse's, and is trusted when |pattern − inverse| ≥ minContrast_dn and
// ≥ minContrastFraction·(white − black): the fraction does not depend on how
// much light the part lets through to that pixel, and the floor in DN keeps
// dim pixels' noise out. Since neighbouring Gray codes differ in one bit, a
// camera pixel that sees the edge between two panel pixels (or blurs across
// it) loses the contrast of exactly that bit and is left undecoded, rather
// than decoded to a panel pixel far away. A code beyond the panel's width or
// height (W, H not powers of two) is undecoded too.
//
// Two sources (DecodeSettings::secondShare > 0): a camera pixel that sees two
// panel columns (rows) at once — straddling two lenses of the display, or
// between two views of one — sees each bit where their codes differ at the
// difference of their shares. Such a bit (|pattern − inverse| below
// (1 − 2·secondShare)·(white − black)) is split, and the pixel decodes to
// both columns: the brighter source's code (each bit's sign) and that code
// with every split bit flipped. With two or more split bits each must reach
// max(minContrast_dn, minContrastFraction·(white − black)), so that its sign
// tells which source is brighter; when their contrasts differ by more than
// that figure the pixel sees more than two sources, and decodes to the
// brightest one alone, as with one source. One split bit needs neither.
// Columns and rows are decoded apart, so a pixel at the corner of four lenses
// decodes to 2 × 2 panel pixels. The confidence of a pixel read as two
// sources is taken over the bits that are not split (1 when every bit is);
// one read as the brightest alone, over all its bits, as with one source.
//
// Confidence of a decoded pixel: the smallest |pattern − inverse| over all its
// bits divided by its white − black, about 1 for a pixel well inside one panel
// pixel's image (noise can take it a little above 1), falling towards 0 as the
// pixel's view approaches a panel pixel's edge. For a 1 × 1 panel (no bits) a
// lit pixel's confidence is 1. Undecoded pixels have confidence 0.

#include <opencv2/core.hpp>

#include <vector>

namespace lfi::calib {

// How many Gray code patterns a panel takes, and where each one is in the
// set. Panel sizes are 1 .. kMaxPanelSide pixels a side.
struct GrayCodeLayout {
  static constexpr int kMaxPanelSide = 65536;

  int panelWidth = 0, panelHeight = 0;  // panel pixels
  int columnBits = 0, rowBits = 0;      // ⌈log2 width⌉, ⌈log2 height⌉

  // Errc::InvalidArgument for a side outside 1 .. kMaxPanelSide.
  static GrayCodeLayout forPanel(int panelWidth, int panelHeight);

  int patternCount() const { return 2 * (columnBits + rowBits); }
  int frameCount() const { return patternCount() + 2; }  // with white and black
  // Index of the pattern of column bit `bit` (0 = most significant), and of
  // row bit `bit`; its inverse is the next one.
  int columnPattern(int bit) const { return 2 * bit; }
  int rowPattern(int bit) const { return 2 * (columnBits + bit); }
};

// The panel images to show, CV_8UC1, panelHeight × panelWidth, 0 or 255.
struct CodedPatternSet {
  GrayCodeLayout layout;
  std::vector<cv::Mat> patterns;  // layout.patternCount() of them, in the order above
  cv::Mat white, black;           // every panel pixel on, every one off
};

// OpenCV's Gray code patterns for a panelWidth × panelHeight panel.
// Errc::InvalidArgument for a side outside 1 .. GrayCodeLayout::kMaxPanelSide.
CodedPatternSet grayCodePatterns(int panelWidth, int panelHeight);

// Thresholds in the frames' DN; the defaults suit 8-bit frames (scale the two DN figures for deeper ones: × 16
// for 12-bit values).
struct DecodeSettings {
  int minLit_dn = 16;                // white − black at least this: the pixel sees the panel (1 .. 65535)
  int minContrast_dn = 4;            // each bit's |pattern − inverse| at least this (1 .. 65535) ...
  double minContrastFraction = 0.2;  // ... and at least this fraction of white − black (0 .. 1)
  double secondShare = 0;            // two sources per axis from this share of the light on ([0, 0.5); 0: one)
};

// Per camera pixel, the panel pixel whose light reaches it.
struct PanelCorrespondence {
  cv::Mat panel;  // CV_32SC2, camera size: (x, y) of the panel pixel, (-1, -1) where undecoded
                  // (with two sources: of the brighter column and the brighter row)
  // With two sources (secondShare > 0; else empty):
  cv::Mat second;      // CV_32SC2: the second source's column and row, -1 for an axis with one source
  cv::Mat share;       // CV_32FC2: the share of the light from `panel`'s column and row (1 with one source)
  cv::Mat confidence;  // CV_32FC1, camera size: as in the header comment, 0 where undecoded
  int lit = 0;         // camera pixels with white − black ≥ minLit_dn
  int decoded = 0;     // camera pixels decoded (all of them lit)
};

// Decodes camera frames of a pattern set: `frames` holds one frame per pattern,
// in the set's order (layout.patternCount() of them), `white` and `black` the
// frames of the all-white and all-black panel. All single-channel, of one type
// (CV_8UC1 or CV_16UC1) and one size. Row bands in parallel on OpenCV's threads.
// Errc::InvalidArgument, naming what: a layout whose bit counts do not fit its
// panel, a wrong number of frames, an empty frame, one of another type or size
// than `white`, a type other than CV_8UC1 or CV_16UC1, settings out of range.
PanelCorrespondence decodeGrayCode(const std::vector<cv::Mat>& frames, const cv::Mat& white, const cv::Mat& black,
                                   const GrayCodeLayout& layout, const DecodeSettings& settings = {});
inline PanelCorrespondence decodeGrayCode(const std::vector<cv::Mat>& frames, const cv::Mat& white,
                                          const cv::Mat& black, const CodedPatternSet& set,
                                          const DecodeSettings& settings = {}) {
  return decodeGrayCode(frames, white, black, set.layout, settings);
}

}  // namespace lfi::calib
