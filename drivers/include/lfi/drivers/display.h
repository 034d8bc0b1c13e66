// SPDX-License-Identifier: Apache-2.0
#pragma once
// The bench's light field display as the rest of the stack sees it: a flat panel
// behind 2-D optics that give full parallax (a lenslet array or a pinhole array:
// integral imaging) or 1-D optics that give horizontal parallax only (a slanted
// lenticular sheet or a line barrier). Backends (the libusb
// `usb:` display, the ray-traced `sim:` display) implement this interface and are
// opened by URI (display_registry.h).
//
// State machine (every backend follows it):
//
//            open()            show(...)
//   Closed ─────────► Open ─────────────► Showing ──┐ show(...)
//      ▲               ▲  ◄──── blank() ───┘   ▲    │ (next frame)
//      │               │                        └────┘
//      └──── close() from any state; a device that vanishes also ends in Closed
//
// Open: connected, the panel is dark (blank); open() also sets the backlight to
// its maximum, and close() blanks the panel. Showing: the panel shows the last
// presented frame. A display returned by openDisplay() is Open. Calling a method in
// a state it does not list throws lfi::Error(Errc::InvalidArgument) naming the
// method and the state.
//
// Units and frame: millimetres and radians. The display frame has its origin at the
// centre of the panel's active area, x along panel columns (left to right), y along
// panel rows upwards (row 0 is the top), z = 0 the emitting plane (the lens/barrier
// plane) and +z from the display towards the part and the camera. This is the light
// field plane frame of light_field.h, so a LightField is encoded in place: the
// optics model (display_optics.h, encodeLightField) turns it into the panel
// image show() takes; a display itself knows panels, not light fields.

#include <opencv2/core.hpp>

#include <chrono>
#include <cstdint>
#include <initializer_list>
#include <optional>
#include <string>

namespace lfi {

class PanelResponse;

// Order of the colour subpixels inside one panel pixel, left to right.
enum class SubpixelLayout { Mono, RgbStripe, BgrStripe };
// The optics over the panel (display_optics.h has the models, one header per class
// under optics/ with its parameter table):
//   Lenticular    slanted cylinder lenses: horizontal parallax only (lenticular_optics.h)
//   LineBarrier   slanted slits, the same geometry without lenses (lenticular_optics.h)
//   LensletArray  a 2-D microlens array, square or hexagonal packing (lens_array_optics.h)
//   PinholeArray  a 2-D array of pinholes, square or hexagonal packing (lens_array_optics.h)
enum class OpticsType { Lenticular, LineBarrier, LensletArray, PinholeArray };
// How a lens or pinhole array is packed: centres on a square grid, or on a
// hexagonal grid (rows of pitch p, every other row shifted by p/2, rows p√3/2 apart).
enum class LensPacking { Square, Hexagonal };

const char* toString(SubpixelLayout layout);
const char* toString(OpticsType type);  // the class as files name it: "lenslet_array"
const char* toString(LensPacking packing);
// Whether the optics send light in every direction of a 2-D grid from each lens.
inline bool fullParallax(OpticsType type) {
  return type == OpticsType::LensletArray || type == OpticsType::PinholeArray;
}

// The optics in front of the panel. Which fields count depends on the class; the
// others are ignored. Units: mm, rad, panel pixels where the name says _px.
struct DisplayOpticsParams {
  OpticsType type = OpticsType::Lenticular;
  // Lenticular and line barrier. Lens axes are lines on the panel tilted by
  // `slant_rad` from the panel's vertical (positive: the axis leans towards +x going up, +y).
  double lensPitch_px = 0;  // distance between neighbouring lens axes along a panel row, in panel pixels
  double slant_rad = 0;     // lens axis angle from the panel vertical
  double offset_px = 0;     // x of lens 0's axis on the panel's centre row, from the panel centre, in pixels
  // Lenslet and pinhole arrays.
  LensPacking packing = LensPacking::Square;
  double arrayPitch_mm = 0;    // centre distance of neighbouring lenses (pinholes) along a lattice row
  double rotation_rad = 0;     // the lattice rows' angle from the panel rows (+x towards +y)
  double arrayOffsetX_mm = 0;  // centre of lens (0, 0) from the panel centre
  double arrayOffsetY_mm = 0;
  double fillFactor = 1;          // lenslet array: the clear aperture, as a linear fraction of a lens's cell
  double pinholeDiameter_mm = 0;  // pinhole array
  // Every class.
  double gap_mm = 0;          // panel (pixel plane) to lens/barrier/pinhole plane
  double focalLength_mm = 0;  // lenticular and lenslet array: focal length of each lens
  double slitWidth_mm = 0;    // line barrier: width of each slit
  friend bool operator==(const DisplayOpticsParams&, const DisplayOpticsParams&) = default;
};

// What the display is. Everything except the identity strings comes from the
// device's calibration at open (a display calibration file named by the usb:
// URI's calibration= key may override the optics: display_calibration_file.h).
struct DisplayInfo {
  std::string vendor;
  std::string model;
  std::string serial;
  std::string deviceId;  // the backend's id, the part after "<scheme>:" that reopens this display
  int panelWidth_px = 0;
  int panelHeight_px = 0;
  double pixelPitch_mm = 0;  // square panel pixels
  SubpixelLayout subpixels = SubpixelLayout::Mono;
  DisplayOpticsParams optics;
  // False for a device that cannot say what is in front of its panel (a monitor: window:): `optics` means
  // nothing until a calibration file or the bench file's [display.optics] gives them.
  bool opticsStated = true;
  int viewCount = 0;  // distinct directions per lens, as the device states it
  int brightnessMin = 0;
  int brightnessMax = 0;

  int subpixelsPerPixel() const { return subpixels == SubpixelLayout::Mono ? 1 : 3; }
  // The panel image type show() takes: CV_8UC1 for Mono, CV_8UC3 otherwise.
  int panelType() const;
  // Throws Errc::InvalidArgument naming the first field out of range, or saying that the optics are not stated.
  void validate() const;
};

// Outcome of one show() (a value, docs/contributing.md): Presented — the device validated and
// shows the frame; Rejected — the device refused it (CRC, size, truncated transfer),
// `message` says why and names the device; Timeout — the transfer did not finish in
// time and was cancelled. The panel keeps showing the previous frame on Rejected and
// Timeout, and the display's state does not change.
enum class PresentStatus { Presented, Rejected, Timeout };
const char* toString(PresentStatus status);

struct PresentResult {
  PresentStatus status = PresentStatus::Timeout;
  std::uint32_t sequence = 0;  // the frame's sequence number on the wire
  std::string message;
};

struct DisplayStatus {
  bool showing = false;
  std::uint32_t presentedSequence = 0;  // last frame shown
  std::uint64_t framesPresented = 0;    // device counters since power-up
  std::uint64_t framesRejected = 0;
  int brightness = 0;
  std::string lastError;            // the device's last error in words, empty if none
  std::uint64_t stallsCleared = 0;  // host side: endpoint halts cleared and frames resent since open()
  // When the last frame was presented (window: the moment the present returned), if the backend knows it.
  std::optional<std::chrono::steady_clock::time_point> lastPresent;
};

// A display device. Non-copyable, non-movable: one object owns one device.
// Methods are not thread-safe; drive a display from one thread.
class Display {
 public:
  enum class State { Closed, Open, Showing };

  Display() = default;
  Display(const Display&) = delete;
  Display& operator=(const Display&) = delete;
  Display(Display&&) = delete;
  Display& operator=(Display&&) = delete;
  virtual ~Display() = default;

  // Any state.
  virtual State state() const = 0;

  // Any state: the device's name in messages, the URI that opens it
  // ("usb:1209:4c46/LFI-0001", "sim:bench.toml").
  virtual std::string name() const = 0;

  // Closed → Open: (re)connects to the device named at creation and reads its
  // info and calibration. Throws Errc::NotFound when the device is not there.
  virtual void open() = 0;

  // Any state → Closed: releases the device. Never throws.
  virtual void close() noexcept = 0;

  // Open, Showing.
  virtual DisplayInfo info() const = 0;

  // Open, Showing → Showing on PresentStatus::Presented. `panel` must be
  // panelWidth_px x panelHeight_px of info().panelType(); channels in the panel's
  // subpixel order left to right. A device that vanishes throws Errc::Device (the
  // display is then Closed).
  virtual PresentResult show(const cv::Mat& panel) = 0;

  // Open, Showing → Open: the panel goes dark.
  virtual void blank() = 0;

  // Open, Showing: level in info().brightnessMin..brightnessMax.
  virtual void setBrightness(int level) = 0;

  // Open, Showing: asks the device.
  virtual DisplayStatus status() = 0;
};

const char* toString(Display::State state);

// For backends: throws Errc::InvalidArgument naming the device unless `panel` is
// a non-empty panelWidth_px x panelHeight_px image of info.panelType().
void requirePanelImage(const DisplayInfo& info, const cv::Mat& panel, const std::string& device);

// The panel image that drives every subpixel of each panel pixel at its level:
// `levels` is CV_8UC1 (drive levels) or CV_32FC1 (fractions of full drive in
// [0, 1], rounded to the nearest of 256 levels; with a measured `response`,
// fractions of the dimmest pixel's full light: panel_response.h), the panel's
// size; a panel image of info.panelType() is returned as it is. Throws
// Errc::InvalidArgument for another type or size or a level outside [0, 1].
cv::Mat panelFromLevels(const cv::Mat& levels, const DisplayInfo& info, const PanelResponse* response = nullptr);

// For backends: throws Errc::InvalidArgument "<device>: <method> is not allowed in
// state <state> (allowed: ...)" unless `current` is one of `allowed`.
void requireDisplayState(Display::State current, std::initializer_list<Display::State> allowed, const char* method,
                         const std::string& device);

}  // namespace lfi
