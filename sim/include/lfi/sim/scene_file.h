// SPDX-License-Identifier: Apache-2.0
#pragma once
// Scene files: a whole bench for the ray tracer in one human-editable TOML
// file (docs/scene-files.md). Errors name the file, line and key; unknown keys
// are errors.

#include "lfi/sim/render.h"
#include "lfi/sim/scene.h"
#include "lfi/sim/sensors.h"

#include <cstdint>
#include <filesystem>
#include <limits>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

namespace lfi::sim {

// [camera_sensor]: the camera's sensor as the `sim:` camera backend models it
// (lfi/sim/devices/camera_sensor_model.h). The exposure scale turns relative radiance
// into electrons: electronsPerUnit = electronsPerUnitPerUs * exposure_us.
struct CameraSensorParameters {
  double fullWell_e = 10500;           // e-
  double readNoise_e = 2.4;            // e- rms
  int bitDepth = 12;                   // ADC bits
  double electronsPerUnitPerUs = 0.7;  // e- per unit radiance per µs: 10 ms gives 7000 e- (2/3 of the well)
  // The fixed pattern (sensor_pattern.h): none by default.
  double blackLevel_dn = 0;       // DN at bit_depth added to every pixel
  double darkFpn_dn = 0;          // rms spread of the pixels' dark offsets, DN
  double gainFpn = 0;             // rms spread of the pixels' relative response (PRNU)
  double vignetting = 0;          // relative loss of response at the sensor's corners
  std::uint64_t patternSeed = 1;  // the pattern's draw
};

// [display]: the simulated light field display (the `sim:` display backend,
// sim_display.h). Defaults are those of defaultLenticularDisplay() (display_optics.h).
struct DisplayParameters {
  DisplayInfo info;         // vendor "lfi", model "SimDisplay"; optics from the file
  Rigid3 worldFromDisplay;  // placement of the display frame (display.h) in the world
  double brightness = 1;    // radiance at drive level 255 and backlight level brightnessMax
  PanelLight light;         // drive to light and the backlight's fall-off: linear and uniform by default
};

// The key that holds a lens value in a scene file's lens shape; the bench
// file's [lens] spells them alike. For naming a sphericalLensFault().
const char* lensKey(LensFault::Part part);

struct SceneDescription {
  std::string name;
  std::vector<Object> objects;  // with [display]: its object last, emitting a dark panel
  double ambientIor = 1.0;
  Sensor sensor;
  RenderOptions render;
  CameraSensorParameters cameraSensor;  // defaults unless the file has [camera_sensor]
  std::optional<DisplayParameters> display;
  int displayObject = -1;  // index of the display's object in `objects`, -1 without [display]
};

SceneDescription loadSceneFile(const std::filesystem::path& path);

// A triangle mesh from Stanford PLY (ASCII or binary; lfi's own reader, which
// checks every count and index against the file) or any other format Assimp
// reads (Wavefront OBJ, STL, ...; polygons are triangulated, identical
// vertices joined, the file's node transforms applied), with per-vertex
// normals: smooth (the area-weighted mean of the faces' normals) across edges
// where faces meet at less than `creaseAngle_rad`, sharp across the others
// (the vertex is then repeated, one copy per smooth group of faces around it),
// so that a tessellated curved surface shades smoothly and a glass cube's faces
// stay flat. Vertices that meshClosureFault counts as one are one for the
// normals; of the faces on one edge any two may join (an edge of more than 8
// is sharp), faces of no area none. The file's coordinates times `scale` are
// millimetres (a vertex then more than kFarthest_mm from the origin is refused);
// faces must wind outwards.
inline constexpr double kDefaultCreaseAngle_deg = 30;

// The bounds a scene file and the sim: devices' URIs keep to, 1 km. No
// coordinate or size of a bench is this far out: such a value is a wrong unit
// or a stand-in for "infinite". Farther out the tracer loses what it is for:
// a ray's crossing with a millimetre part, computed in double from the ray's
// origin, is off by micrometres from 1e7 mm (measured: up to 2.7 µm on a
// ball of radius 10 mm; from 1e6 mm within 1 µm, test
// RaysFromTheFarthestSensorMeetWhatNearbyRaysMeet),
// and Embree, which takes origins in float, passed beside whole parts from
// 1e8 mm on.
inline constexpr double kFarthest_mm = 1e6;
inline constexpr int kMostSamplesPerPixel = 1 << 20;
// The narrowest cone a parallel emitter (and the sim capture's beam) takes: below
// about 1e-8 rad its cosine rounds to 1 and it lights nothing.
inline constexpr double kNarrowestCone_rad = 1e-6;
// The largest seed: TOML's largest integer, so that any seed `lfi render --seed` takes can be written in a scene file.
inline constexpr std::int64_t kLargestSeed = std::numeric_limits<std::int64_t>::max();

TriangleMesh loadMesh(const std::filesystem::path& path,
                      double creaseAngle_rad = kDefaultCreaseAngle_deg * std::numbers::pi / 180, double scale = 1);

// Why `mesh` does not bound a solid the tracer can enter and leave, or nothing:
// every edge must be crossed once each way by the triangles around it (vertices
// closer than 1e-7 of the mesh's size, or of its distance from the origin where
// that is larger, are one vertex; triangles with two such vertices are
// skipped), the enclosed volume must be positive (outward winding), and so must
// each closed part's, but for a cavity (a part inside an odd number of the
// others), which must be wound inwards. A dielectric mesh must pass; an opaque
// one may be an open surface.
std::optional<std::string> meshClosureFault(const TriangleMesh& mesh);

// position (mm) and rotation (degrees, applied about x, then y, then z).
Rigid3 placement(const std::vector<double>& position_mm, const std::vector<double>& rotation_deg);

}  // namespace lfi::sim
