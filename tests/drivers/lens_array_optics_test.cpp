// SPDX-License-Identifier: Apache-2.0
// The full-parallax display classes (lenslet and pinhole arrays, optics/*.h)
// against analytic geometry: the lattice, chief rays and their inverse over
// whole panels, the thin-lens back trace, encoding and decoding, bad input.

#include "lfi_test_support.h"

#include "lfi/drivers/display.h"
#include "lfi/drivers/display_calibration_file.h"
#include "lfi/drivers/display_optics.h"
#include "lfi/drivers/optics/lens_lattice.h"
#include "lfi/drivers/usb/usb_display_protocol.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <random>
#include <string>
#include <vector>

namespace lfi {
namespace {

using testing_support::throwsError;

// A small panel (mono or RGB) behind an array of 1 mm lenses: about 32 pixels per lens.
DisplayInfo smallArray(OpticsType type, LensPacking packing, double rotation_rad, Vec2 offset_mm,
                       SubpixelLayout layout = SubpixelLayout::Mono) {
  DisplayInfo info = type == OpticsType::LensletArray ? defaultLensletArrayDisplay() : defaultPinholeArrayDisplay();
  info.panelWidth_px = 160;
  info.panelHeight_px = 120;
  info.subpixels = layout;
  info.optics.packing = packing;
  info.optics.rotation_rad = rotation_rad;
  info.optics.arrayOffsetX_mm = offset_mm.x;
  info.optics.arrayOffsetY_mm = offset_mm.y;
  return info;
}

struct ArrayCase {
  OpticsType type;
  LensPacking packing;
  double rotation_rad;
  Vec2 offset_mm;
};

std::vector<ArrayCase> arrayCases() {
  std::vector<ArrayCase> cases;
  for (OpticsType type : {OpticsType::LensletArray, OpticsType::PinholeArray})
    for (LensPacking packing : {LensPacking::Square, LensPacking::Hexagonal})
      for (double rotation : {0.0, 0.13, -0.7})
        for (Vec2 offset : {Vec2(0, 0), Vec2(0.31, -0.17)}) cases.push_back({type, packing, rotation, offset});
  return cases;
}

std::string describe(const ArrayCase& c) {
  return fmt::format("{} {} rotation {} offset ({}, {})", toString(c.type), toString(c.packing), c.rotation_rad,
                     c.offset_mm.x, c.offset_mm.y);
}

TEST(LensLattice, NearestCentreIsTheNearestLatticePoint) {
  // Against brute force over the lattice points around the answer.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> coordinate(-20, 20);
  for (LensPacking packing : {LensPacking::Square, LensPacking::Hexagonal})
    for (double rotation : {0.0, 0.4, -0.785}) {
      const double pitch = 1.3, c = std::cos(rotation), s = std::sin(rotation);
      const Vec2 offset(0.2, -0.45);
      const LensLattice lattice(packing, pitch, rotation, offset);
      const Vec2 a1(pitch, 0),
          a2 = packing == LensPacking::Square ? Vec2(0, pitch) : Vec2(0.5 * pitch, 0.5 * std::sqrt(3.0) * pitch);
      for (int n = 0; n < 2000; ++n) {
        const Vec2 p(coordinate(rng), coordinate(rng));
        const Vec2 found = lattice.nearestCentre(p);
        double best = std::numeric_limits<double>::infinity();
        for (int i = -40; i <= 40; ++i)
          for (int j = -40; j <= 40; ++j) {
            const Vec2 local = double(i) * a1 + double(j) * a2;
            const Vec2 centre = offset + Vec2(c * local.x - s * local.y, s * local.x + c * local.y);
            best = std::min(best, (p - centre).length());
          }
        ASSERT_NEAR((p - found).length(), best, 1e-9) << toString(packing) << " " << rotation;
        ASSERT_LE((p - found).length(), lattice.circumradius_mm() + 1e-9);
      }
    }
}

TEST(LensArrayOptics, PixelRayPixelRoundTripOverWholePanels) {
  for (const ArrayCase& c : arrayCases())
    for (SubpixelLayout layout : {SubpixelLayout::Mono, SubpixelLayout::RgbStripe}) {
      const DisplayOptics optics(smallArray(c.type, c.packing, c.rotation_rad, c.offset_mm, layout));
      const DisplayInfo& info = optics.info();
      const double gap = info.optics.gap_mm;
      for (int row = 0; row < info.panelHeight_px; ++row)
        for (int col = 0; col < info.panelWidth_px; ++col)
          for (int k = 0; k < info.subpixelsPerPixel(); ++k) {
            const DisplayRay ray = optics.rayFromPixel(col, row, k);
            const Vec2 p = optics.subpixelCentre(col, row, k);
            // The chief ray: from the subpixel centre through the centre of the lens above it.
            const Vec2 centre = optics.apertureCentre(p);
            ASSERT_EQ(Vec2(ray.origin_mm.x, ray.origin_mm.y), centre);
            ASSERT_EQ(ray.origin_mm.z, 0);
            const Vec3 expected = Vec3(centre.x - p.x, centre.y - p.y, gap).normalized();
            ASSERT_NEAR((ray.direction - expected).length(), 0, 1e-14);
            const auto back = optics.pixelFromRay(ray.origin_mm, ray.direction);
            ASSERT_TRUE(back.has_value()) << describe(c) << " at " << col << "," << row << "," << k;
            ASSERT_EQ(*back, (PanelSample{col, row, k})) << describe(c);
          }
    }
}

TEST(LensArrayOptics, RayPixelRayKeepsTheLensAndTheDirectionWithinHalfASubpixel) {
  // A ray through a lens's clear aperture, inside the view cone, picks the
  // subpixel whose area holds the point c - gap t; that subpixel's chief ray
  // leaves the same lens, and its slope differs from t by at most half the
  // subpixel's diagonal over the gap.
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> unit(-1, 1);
  for (const ArrayCase& c : arrayCases()) {
    const DisplayOptics optics(smallArray(c.type, c.packing, c.rotation_rad, c.offset_mm, SubpixelLayout::RgbStripe));
    const DisplayInfo& info = optics.info();
    const double gap = info.optics.gap_mm, p = info.pixelPitch_mm;
    const double halfDiagonal = 0.5 * std::hypot(p / 3, p);
    const double reach = c.type == OpticsType::PinholeArray ? 0.5 * info.optics.pinholeDiameter_mm : 0.3;
    int found = 0;
    for (int n = 0; n < 4000; ++n) {
      const Vec2 lens = optics.apertureCentre({unit(rng) * 1.2, unit(rng) * 0.8});  // (keeps c - gap t on the panel)
      const Vec2 q = lens + reach * Vec2(unit(rng), unit(rng)) / std::sqrt(2.0);
      const Vec2 t = 0.35 * Vec2(unit(rng), unit(rng));  // mostly within the view cone
      const Vec3 d = Vec3(t.x, t.y, 1).normalized();
      const auto s = optics.pixelFromRay({q.x, q.y, 0}, d);
      const Vec2 exact = lens - gap * t;
      if (!s) {
        // Only where c - gap t, or the centre of the subpixel that holds it, lies under another lens.
        const auto holder = optics.grid().sampleAt(exact);
        ASSERT_TRUE(optics.apertureCentre(exact) != lens || !holder ||
                    optics.apertureCentre(optics.subpixelCentre(holder->col, holder->row, holder->subpixel)) != lens)
            << describe(c);
        continue;
      }
      ++found;
      const DisplayRay ray = optics.rayFromPixel(*s);
      ASSERT_EQ(Vec2(ray.origin_mm.x, ray.origin_mm.y), lens) << describe(c);
      const Vec2 slope(ray.direction.x / ray.direction.z, ray.direction.y / ray.direction.z);
      ASSERT_LE((slope - t).length(), halfDiagonal / gap * (1 + 1e-9)) << describe(c);
      ASSERT_EQ(optics.pixelFromRay(ray.origin_mm, ray.direction), s);
    }
    EXPECT_GT(found, 2000) << describe(c);
  }
}

TEST(LensArrayOptics, TheViewConeEndsAtTheCellEdge) {
  // Along a lattice row the cell ends at P/2 from the centre: a chief ray up to
  // atan(P / (2 gap)) from the axis has a pixel, one past it has none.
  for (LensPacking packing : {LensPacking::Square, LensPacking::Hexagonal}) {
    const double rotation = 0.13;
    const DisplayOptics optics(smallArray(OpticsType::LensletArray, packing, rotation, {0, 0}));
    const double gap = optics.info().optics.gap_mm, pitch = optics.info().optics.arrayPitch_mm;
    EXPECT_NEAR(optics.viewCone_rad(), 2 * std::atan(0.5 * pitch / gap), 1e-15);
    const Vec2 row(std::cos(rotation), std::sin(rotation));
    for (double sign : {-1.0, 1.0}) {
      const Vec2 inside = sign * 0.49 * pitch / gap * row, outside = sign * 0.51 * pitch / gap * row;
      EXPECT_TRUE(optics.pixelFromRay({0, 0, 0}, Vec3(inside.x, inside.y, 1).normalized()).has_value());
      EXPECT_FALSE(optics.pixelFromRay({0, 0, 0}, Vec3(outside.x, outside.y, 1).normalized()).has_value());
    }
    EXPECT_FALSE(optics.pixelFromRay({0, 0, 0}, {0, 0, -1}).has_value());
    EXPECT_FALSE(optics.pixelFromRay({1000, 0, 0}, {0, 0, 1}).has_value());  // off the panel
  }
}

TEST(LensArrayOptics, FullParallaxFansRaysAcrossAndAlongThePanelRows) {
  // A lenticular display sends every ray in the plane across its lens axes: the
  // component along the axis is zero whatever the pixel. A lenslet array sends
  // rays up to the half cone both ways.
  const DisplayOptics lenticularOptics(defaultLenticularDisplay());
  const LenticularOptics& lenticular = *lenticularOptics.model<LenticularOptics>();
  const Vec2 axis(lenticular.lensNormal().y * -1, lenticular.lensNormal().x);
  double alongMax = 0;
  for (int row = 0; row < 300; row += 7)
    for (int col = 0; col < 300; col += 5) {
      const Vec3 d = lenticularOptics.rayFromPixel(col, row, 1).direction;
      alongMax = std::max(alongMax, std::abs(d.x * axis.x + d.y * axis.y));
    }
  EXPECT_LT(alongMax, 1e-12);
  EXPECT_FALSE(lenticularOptics.fullParallax());

  const DisplayOptics array(smallArray(OpticsType::LensletArray, LensPacking::Square, 0, {0, 0}));
  EXPECT_TRUE(array.fullParallax());
  double xMax = 0, yMax = 0;
  for (int row = 0; row < 120; ++row)
    for (int col = 0; col < 160; ++col) {
      const Vec3 d = array.rayFromPixel(col, row).direction;
      xMax = std::max(xMax, d.x / d.z);
      yMax = std::max(yMax, d.y / d.z);
    }
  const double halfPitchSlope = 0.5 * array.info().optics.arrayPitch_mm / array.info().optics.gap_mm;
  const double pixelSlope = array.info().pixelPitch_mm / array.info().optics.gap_mm;
  EXPECT_GT(xMax, halfPitchSlope - pixelSlope);
  EXPECT_GT(yMax, halfPitchSlope - pixelSlope);
}

TEST(LensArrayOptics, ClearApertureAndPinholeStopRays) {
  DisplayInfo lenslet = smallArray(OpticsType::LensletArray, LensPacking::Square, 0, {0, 0});
  lenslet.optics.fillFactor = 0.5;  // the clear aperture: the middle 0.5 x 0.5 mm of each 1 mm cell
  const DisplayOptics lens(lenslet);
  const Vec3 up(0, 0, 1);
  EXPECT_TRUE(lens.pixelFromRay({0.24, 0.1, 0}, up).has_value());
  EXPECT_FALSE(lens.pixelFromRay({0.26, 0.1, 0}, up).has_value());
  EXPECT_TRUE(lens.sourceOfRay({0.24, -0.24}, up).has_value());
  EXPECT_FALSE(lens.sourceOfRay({0.1, -0.26}, up).has_value());

  const DisplayOptics pinholes(smallArray(OpticsType::PinholeArray, LensPacking::Hexagonal, 0, {0, 0}));
  const double radius = 0.5 * pinholes.info().optics.pinholeDiameter_mm;
  EXPECT_TRUE(pinholes.pixelFromRay({0.99 * radius, 0, 0}, up).has_value());
  EXPECT_FALSE(pinholes.pixelFromRay({1.01 * radius, 0, 0}, up).has_value());
  EXPECT_TRUE(pinholes.sourceOfRay({0, 0.99 * radius}, up).has_value());
  EXPECT_FALSE(pinholes.sourceOfRay({0, 1.01 * radius}, up).has_value());
  // The next pinhole of a hexagonal row is one pitch along x: open again there.
  EXPECT_TRUE(pinholes.sourceOfRay({pinholes.info().optics.arrayPitch_mm, 0}, up).has_value());
}

TEST(LensArrayOptics, TheBackTraceIsTheThinLensForwardTrace) {
  // Forward: a ray from panel point p to the lens plane at q = c + h has slope
  // (q - p) / gap and leaves a thin lens of focal length f with slope
  // (q - p) / gap - h / f. The back trace of that ray must return p; with f =
  // gap every point of the aperture sees the same p for one direction.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> unit(-1, 1);
  for (double focalFactor : {1.0, 2.0, 0.8}) {
    DisplayInfo info = smallArray(OpticsType::LensletArray, LensPacking::Hexagonal, 0.2, {0.1, 0.05});
    info.optics.focalLength_mm = focalFactor * info.optics.gap_mm;
    const DisplayOptics optics(info);
    const double gap = info.optics.gap_mm, f = info.optics.focalLength_mm;
    for (int n = 0; n < 500; ++n) {
      const Vec2 c = optics.apertureCentre({0.8 * unit(rng), 0.6 * unit(rng)});  // (keeps p on the panel)
      const Vec2 h = 0.3 * Vec2(unit(rng), unit(rng)), q = c + h;
      const Vec2 p = c + 0.4 * Vec2(unit(rng), unit(rng));
      const Vec2 slope = (q - p) / gap - h / f;
      const auto source = optics.sourceOfRay(q, Vec3(slope.x, slope.y, 1).normalized());
      ASSERT_TRUE(source.has_value());
      const auto expected = optics.grid().sampleAt(p);
      ASSERT_EQ(source, expected) << "f = " << focalFactor << " gap";
    }
  }
  // Focused: the same direction from anywhere in the aperture comes from one panel point.
  const DisplayOptics focused(smallArray(OpticsType::LensletArray, LensPacking::Square, 0, {0, 0}));
  const Vec3 d = Vec3(0.1, -0.2, 1).normalized();
  const auto middle = focused.sourceOfRay({0, 0}, d);
  ASSERT_TRUE(middle.has_value());
  for (Vec2 q : {Vec2(0.45, 0.45), Vec2(-0.45, 0.1), Vec2(0.2, -0.45)}) EXPECT_EQ(focused.sourceOfRay(q, d), middle);
}

TEST(LensArrayOptics, SteepRaysComeFromUnderTheNeighbouringLens) {
  // Past the view cone a lens still passes light, from the pixels under its
  // neighbour: the repeated view zones of an integral-imaging display.
  const DisplayOptics optics(smallArray(OpticsType::LensletArray, LensPacking::Square, 0, {0, 0}));
  const double gap = optics.info().optics.gap_mm;
  const Vec3 steep = Vec3(-0.8 / gap, 0, 1).normalized();  // c - gap t lands 0.8 mm to the right: next lens
  const auto source = optics.sourceOfRay({0, 0}, steep);
  ASSERT_TRUE(source.has_value());
  const Vec2 p = optics.subpixelCentre(source->col, source->row, source->subpixel);
  EXPECT_EQ(optics.apertureCentre(p), Vec2(1, 0));
  EXPECT_FALSE(optics.pixelFromRay({0, 0, 0}, steep).has_value());  // no chief ray of lens (0, 0) goes there
}

TEST(LensArrayOptics, EncodingThenDecodingReturnsTheLightFieldWithinTheDisplaysResolution) {
  // L(q, d) = 0.5 + 0.5 sx - 0.3 sy on the disc (s = (-dx, -dy)), the same in every
  // element: linear in the disc coordinate, which the interpolated lookup
  // reproduces. Encoded, the subpixel of chief slope t holds L(t); decoded, a
  // sample of slope t' reads the subpixel whose area holds c - gap t', whose slope
  // is within half a subpixel diagonal over the gap of t'. The disc coordinate
  // moves by at most the slope, so the error is at most 0.8 of that plus half a
  // drive level (8-bit rounding).
  for (OpticsType type : {OpticsType::LensletArray, OpticsType::PinholeArray})
    for (LensPacking packing : {LensPacking::Square, LensPacking::Hexagonal}) {
      const DisplayOptics optics(smallArray(type, packing, 0.1, {0.2, 0.1}, SubpixelLayout::RgbStripe));
      const DisplayInfo& info = optics.info();
      // 16 x 12 elements of 0.6 mm: twice the panel, so that no lens's lookup nears the plane's edge.
      const LightFieldGeometry g{.spatialX = 16, .spatialY = 12, .angular = 15, .pixelPitch_mm = 0.04};
      LightField lf(g);
      auto value = [](const Vec2& s) { return 0.5 + 0.5 * s.x - 0.3 * s.y; };
      for (int ey = 0; ey < g.spatialY; ++ey)
        for (int ex = 0; ex < g.spatialX; ++ex)
          for (int v = 0; v < g.angular; ++v)
            for (int u = 0; u < g.angular; ++u) {
              const Vec2 s = lf.angularCentre(u, v);
              lf.at(ex, ey, u, v) = s.length2() < 1 ? static_cast<float>(value(s)) : 0.f;
            }
      const cv::Mat panel = encodeLightField(lf, optics);
      const LightField decoded = decodePanelImage(panel, optics, g);
      const double slopeError = 0.5 * std::hypot(info.pixelPitch_mm / 3, info.pixelPitch_mm) / info.optics.gap_mm;
      const double tolerance = 0.8 * slopeError + 0.5 / 255 + 1e-6;
      int compared = 0;
      for (int ey = 0; ey < g.spatialY; ++ey)
        for (int ex = 0; ex < g.spatialX; ++ex)
          for (int v = 0; v < g.angular; ++v)
            for (int u = 0; u < g.angular; ++u) {
              const Vec2 q = lf.elementCentre(ex, ey);
              if (std::abs(q.x) > 1.5 || std::abs(q.y) > 1.0) continue;  // (lenses whose pixels are on the panel)
              const Vec2 s = lf.angularCentre(u, v);
              const Vec3 d = LightField::directionFromDisc(s);
              const Vec2 lens = optics.apertureCentre(q);
              if (!(s.length2() < 0.09) || !optics.pixelFromRay({lens.x, lens.y, 0}, d)) continue;
              ASSERT_NEAR(decoded.at(ex, ey, u, v), value(s), tolerance)
                  << toString(type) << " " << toString(packing) << " element " << ex << "," << ey;
              ++compared;
            }
      EXPECT_GT(compared, 300);  // 24 elements x about 16 directions within |s| < 0.3
    }
}

TEST(LensArrayOptics, BadParametersAreNamed) {
  struct Case {
    const char* field;
    void (*spoil)(DisplayOpticsParams&);
  };
  const std::vector<Case> cases = {
      {"arrayPitch_mm", [](DisplayOpticsParams& o) { o.arrayPitch_mm = 0; }},
      {"arrayPitch_mm", [](DisplayOpticsParams& o) { o.arrayPitch_mm = 0.01; }},  // below one pixel
      {"rotation_rad", [](DisplayOpticsParams& o) { o.rotation_rad = 0.9; }},
      {"gap_mm", [](DisplayOpticsParams& o) { o.gap_mm = 200; }},
      {"fillFactor", [](DisplayOpticsParams& o) { o.fillFactor = 0; }},
      {"focalLength_mm", [](DisplayOpticsParams& o) { o.focalLength_mm = -1; }},
      {"arrayOffsetX_mm", [](DisplayOpticsParams& o) { o.arrayOffsetX_mm = std::nan(""); }},
  };
  for (const Case& c : cases) {
    DisplayInfo info = defaultLensletArrayDisplay();
    c.spoil(info.optics);
    EXPECT_TRUE(throwsError([&] { DisplayOptics{info}; }, Errc::InvalidArgument, {"display info", c.field})) << c.field;
  }
  DisplayInfo pinhole = defaultPinholeArrayDisplay();
  pinhole.optics.pinholeDiameter_mm = 1.5;  // larger than its 1 mm pitch
  EXPECT_TRUE(throwsError([&] { pinhole.validate(); }, Errc::InvalidArgument, {"pinholeDiameter_mm"}));
}

TEST(UsbDisplayProtocol, CalibrationBlocksCarryEveryClassAndOlderBlocksStayReadable) {
  // Version 2 holds every class; a version 1 block (the lenticular and
  // line-barrier classes only) reads as before.
  for (const DisplayInfo& info : {defaultLensletArrayDisplay(), defaultPinholeArrayDisplay()}) {
    DisplayInfo hex = info;
    hex.optics.packing = LensPacking::Hexagonal;
    hex.optics.rotation_rad = 0.2;
    hex.optics.arrayOffsetX_mm = -0.3;
    hex.optics.arrayOffsetY_mm = 0.4;
    const usbdisplay::CalibrationBlock block = usbdisplay::toCalibrationBlock(hex.pixelPitch_mm, hex.optics);
    EXPECT_EQ(block.version, usbdisplay::kCalibrationVersion2);
    const auto bytes = usbdisplay::encodeCalibration(block);
    EXPECT_EQ(bytes.size(), 124u);
    const usbdisplay::CalibrationBlock back = usbdisplay::decodeCalibration(bytes, "dev");
    EXPECT_EQ(usbdisplay::toOpticsParams(back), hex.optics);
    EXPECT_EQ(back.pixelPitch_mm, hex.pixelPitch_mm);
  }
  const DisplayInfo lenticular = defaultLenticularDisplay();
  const usbdisplay::CalibrationBlock old = usbdisplay::toCalibrationBlock(lenticular.pixelPitch_mm, lenticular.optics);
  EXPECT_EQ(old.version, usbdisplay::kCalibrationVersion1);
  const auto oldBytes = usbdisplay::encodeCalibration(old);
  EXPECT_EQ(oldBytes.size(), 76u);
  const DisplayOpticsParams read = usbdisplay::toOpticsParams(usbdisplay::decodeCalibration(oldBytes, "dev"));
  EXPECT_EQ(read.type, OpticsType::Lenticular);
  EXPECT_EQ(read.lensPitch_px, lenticular.optics.lensPitch_px);
  EXPECT_EQ(read.focalLength_mm, lenticular.optics.focalLength_mm);
  usbdisplay::CalibrationBlock array = usbdisplay::toCalibrationBlock(0.0315, defaultLensletArrayDisplay().optics);
  array.version = usbdisplay::kCalibrationVersion1;
  EXPECT_TRUE(throwsError([&] { usbdisplay::encodeCalibration(array); }, Errc::InvalidArgument, {"version 1"}));
}

TEST(UsbDisplayProtocol, AnUnknownClassOrABadArrayIsRefusedNamingTheDeviceAndField) {
  using Edit = std::function<void(std::vector<std::uint8_t>&)>;
  auto sealed = [](Edit edit) -> Edit {  // the edit, then a CRC-32 that matches: the field check itself is reached
    return [edit](std::vector<std::uint8_t>& b) {
      edit(b);
      const std::uint32_t crc = usbdisplay::crc32Of(std::span(b).first(b.size() - 4));
      for (int i = 0; i < 4; ++i) b[b.size() - 4 + i] = static_cast<std::uint8_t>(crc >> (8 * i));
    };
  };
  auto put8 = [](std::size_t at, std::uint8_t v) -> Edit { return [=](auto& b) { b[at] = v; }; };
  auto putF64 = [](std::size_t at, double v) -> Edit {
    return [=](std::vector<std::uint8_t>& b) { std::memcpy(b.data() + at, &v, sizeof v); };
  };
  const DisplayInfo pinhole = defaultPinholeArrayDisplay();
  const auto good =
      usbdisplay::encodeCalibration(usbdisplay::toCalibrationBlock(pinhole.pixelPitch_mm, pinhole.optics));
  ASSERT_NO_THROW(usbdisplay::decodeCalibration(good, "dev"));
  const std::vector<std::pair<Edit, std::string>> cases = {
      {sealed(put8(8, 7)), "optics class code 7 is unknown"},
      {sealed(put8(9, 2)), "packing code 2"},
      {sealed(putF64(72, 0)), "'arrayPitch'"},               // a pitch of zero
      {sealed(putF64(80, 1.0)), "'rotation'"},               // past pi/4
      {sealed(putF64(48, 150)), "'gap'"},                    // out of range
      {sealed(putF64(112, 1.5)), "'pinholeDiameter'"},       // larger than its 1 mm pitch
      {sealed(putF64(88, std::nan(""))), "'arrayOffsetX'"},  // not a number
  };
  for (const auto& [edit, message] : cases) {
    std::vector<std::uint8_t> bytes = good;
    edit(bytes);
    EXPECT_TRUE(throwsError([&] { usbdisplay::decodeCalibration(bytes, "usb:1209:4c46/X"); }, Errc::Device,
                            {"usb:1209:4c46/X", message}))
        << message;
  }
  // A version 1 block knows only codes 0 and 1.
  const DisplayInfo lenticular = defaultLenticularDisplay();
  auto old = usbdisplay::encodeCalibration(usbdisplay::toCalibrationBlock(lenticular.pixelPitch_mm, lenticular.optics));
  sealed(put8(8, 2))(old);
  EXPECT_TRUE(throwsError([&] { usbdisplay::decodeCalibration(old, "dev"); }, Errc::Device,
                          {"dev", "optics class code 2 is unknown", "version 1"}));
}

TEST(DisplayCalibrationFile, ArrayKeysAreReadAndKeysOfAnotherClassAreNamed) {
  const auto file = std::filesystem::path(::testing::TempDir()) / fmt::format("lfi-array-cal-{}.toml", ::getpid());
  const DisplayOpticsParams device = defaultLenticularDisplay().optics;
  auto read = [&](const std::string& optics) {
    std::ofstream(file) << "format = \"lfi-display-calibration\"\nversion = 1\n[optics]\n" << optics;
    return readDisplayOpticsFile(file, device);
  };
  const DisplayOpticsParams p = read(
      "optics = \"lenslet_array\"\npacking = \"hexagonal\"\narray_pitch_mm = 0.8\nrotation_rad = 0.05\n"
      "array_offset_mm = [0.1, -0.2]\nfill_factor = 0.9\ngap_mm = 1.2\n");
  EXPECT_EQ(p.type, OpticsType::LensletArray);
  EXPECT_EQ(p.packing, LensPacking::Hexagonal);
  EXPECT_EQ(p.arrayPitch_mm, 0.8);
  EXPECT_EQ(p.rotation_rad, 0.05);
  EXPECT_EQ(p.arrayOffsetX_mm, 0.1);
  EXPECT_EQ(p.arrayOffsetY_mm, -0.2);
  EXPECT_EQ(p.fillFactor, 0.9);
  EXPECT_EQ(p.focalLength_mm, 1.2);  // focused on the panel: the gap, when only the gap is given
  EXPECT_TRUE(throwsError([&] { read("optics = \"lenslet_array\"\narray_pitch_mm = 1\nslant_rad = 0.1\n"); },
                          Errc::Config, {file.string() + ":", "slant_rad", "not a parameter of lenslet_array"}));
  EXPECT_TRUE(throwsError([&] { read("optics = \"pinhole_array\"\narray_pitch_mm = 1\n"); }, Errc::Config,
                          {"pinhole_diameter_mm"}));  // required, and the device has none
  EXPECT_TRUE(throwsError([&] { read("optics = \"pinhole_array\"\narray_pitch_mm = 1\npinhole_diameter_mm = 1.2\n"); },
                          Errc::Config, {"pinhole_diameter_mm", "larger than the array pitch"}));
  EXPECT_TRUE(throwsError([&] { read("optics = \"hologram\"\n"); }, Errc::Config, {"optics.optics"}));
  std::filesystem::remove(file);
}

}  // namespace
}  // namespace lfi
