// SPDX-License-Identifier: Apache-2.0
#pragma once
// The inspection bench file: one TOML file that describes a bench (its
// devices, how the camera runs, the geometry, where the reference lives, how
// parts are judged and where records go). Every key is checked; errors name
// the file, line and key (docs/inspection.md lists every key with its units).
// Relative paths and the paths of sim: URIs are relative to the bench file.
//
//   table          key                    units  default     meaning
//   (top)          format, version        -      required    "lfi-inspection-bench", 1
//                  coverage_factor        -      2           k of every calibrated value's uncertainty `<key>_u`
//   any table      <key>_u                as key none        the expanded uncertainty (k = coverage_factor) of a
//                                                             calibrated value: [camera] object_pixel_mm; [geometry]
//                                                             distance_mm, part_centre_px, display_per_pixel_mm,
//                                                             display_at_image_centre_mm; [display.optics] its class's
//                                                             optics' numbers; [display.response] its curves and
//                                                             backlight. As many numbers as the value, each >= 0
//   [camera]       uri                    -      required    aravis:<id>, sim:<scene-file>
//                  exposure_us            µs     required
//                  gain                   dev.   0           device unit (SFNC: dB)
//                  pixel_format           -      "Mono12"    Mono8 | Mono12 | Mono16
//                  trigger                -      "software"  software | free_run | line
//                  trigger_line           -      "Line0"     with trigger = "line"
//                  frame_rate_hz          Hz     0           with trigger = "free_run"; 0 = the device's
//                  binning                -      1
//                  object_pixel_mm        mm     required    one camera pixel on the part (pitch / magnification)
//                  read_noise_dn          DN     required    camera read noise, in the pixel format's DN
//                  dn_per_electron        DN/e-  required    conversion gain (shot noise variance = this · level)
//                  grab_timeout_ms        ms     5000        per frame, beyond twice the exposure
//                  retries                -      3           bad or late frames tolerated per image
//                  dark_frame             path   none        the camera's dark frame (frame_correction.h; `lfi
//                                                             calibrate camera --dark` writes it)
//                  flat_frame             path   none        its flat frame (needs dark_frame; `--flat`)
//   [display]      uri                    -      required    usb:<vid>:<pid>[/<serial>], sim:<scene-file>
//                  settle_ms              ms     0           the panel's response time after a show
//                  white                  -      0           radiance at full drive; 0 = the reference's 99.9th
//                  percentile
//   [display.optics]  optics, ...          mm/rad none        the display's optics as calibrated (`lfi calibrate
//                                                             display`), in place of what the device states: the
//                                                             keys of display_calibration_file.h, the class and
//                                                             every value it needs
//   [display.response]  levels, light   -     none        the panel's drive-to-light curve (or red, green, blue)
//                  (or red, green, blue),               and backlight as `lfi calibrate panel` measured them
//                  backlight, <key>_u                   (panel_response.h), with their uncertainties
//   [capture]      uri  | light_field     -      one of      the reference's capture (sim:, coded:), or a light field
//                                                             file; the capture is handed Δ from [geometry]
//   [geometry]     distance_mm            mm     required    Δ: display plane to the part's reference plane (its
//                                                             one place: a capture URI never carries it)
//                  part_centre_px         px     centre      [column, row] of the part's origin on the image
//                  display_per_pixel_mm   mm/px  none        [a, b, c, d]: the display point a camera pixel sees,
//                                                             (x, y) = [[a, b], [c, d]] (u - u0, v - v0) + the
//                                                             next key, (u0, v0) the image's centre (both keys or
//                                                             neither; `lfi calibrate display` writes them)
//                  display_at_image_centre_mm mm none        [x, y]: the display point the image's centre sees
//                  part_model             path   none        the part's model, a scene file (ScenePartModel): each
//                                                             defect is also placed inside the part, traced back
//                                                             through its surfaces
//                  defect_depth_mm        mm     0           the height in the part's frame, above its reference
//                                                             point, at which the defects inside it are placed
//   [reference]    folder                 path   required    the reference package (reference_package.h)
//                  frames                 -      16          frames of the intact part the golden model starts from
//                  mask_radius_mm         mm     none        the part: a disc around part_centre_px (none: whole image)
//                  mask_lit_fraction      -      0.25        ... and lit at least this fraction of the ideal's 99th
//                  percentile
//   [inspection]   frames                 -      1           frames averaged per part
//                  absolute_dn            DN     0           a: the least difference that counts
//                  relative               -      6           b: the threshold in units of the variation
//                  smallest_defect_mm     mm     0           diameter the smoothing is matched to (σ = d / 4)
//                  closing_mm             mm     0           radius of the closing that joins fragments
//                  min_defect_area_mm2    mm²    0           smaller regions are not defects
//                  max_defects            -      0           pass/fail rules (verdict.h)
//                  max_defect_area_mm2    mm²    none
//                  max_total_area_mm2     mm²    none
//   [output]       folder                 path   required    where inspect and run write records and images
//                  save_images            -      "failed"    all | failed | none: the part images kept
//   [run]          on_device_loss         -      "stop"      stop | wait: wait for the device to come back
//                  wait_limit_s           s      60          how long to wait, with a bounded back-off
//   [output.mqtt]  broker                 -      required    mqtt://host[:port] (1883) or mqtts://host[:port] (8883)
//   (a run's       topic                  -      required    topic prefix: <topic>/record, <topic>/state
//   records and    qos                    -      1           0 | 1 | 2 for the records (the state: 1)
//   state to an    client_id              -      "lfi-<host>-<pid>"
//   MQTT broker,   credentials_file       path   none        a file holding "<username>:<password>" on its first line
//   mqtt_output.h) ca_file                path   none        mqtts: the CA certificates (PEM); none: the system's
//                  cert_file, key_file    path   none        mqtts: the client's certificate and key (PEM), both or
//                  neither queue_limit            -      1000        records held while the broker is away keepalive_s
//                  s      10          the MQTT keep-alive, and so how soon the last will fires drain_s                s
//                  5           at the end of a run, how long to wait for the queue
//   [output.line]  line                   -      "Line1"     the camera's output line (LineSelector) pulsed on a
//   (reject_line.h)                                           failed part
//                  user_output            -      "UserOutput0"  its source (LineSource; UserOutputSelector)
//                  pulse_ms               ms     50          how long the line stays high
//
// Units: mm, rad, µs; frames: image pixels (OpenCV's: top-left centre (0, 0)),
// the part's frame as verdict.h defines it.

#include "lfi/calib/camera_scale.h"
#include "lfi/drivers/camera.h"
#include "lfi/drivers/device_uri.h"
#include "lfi/drivers/display.h"
#include "lfi/drivers/panel_response.h"
#include "lfi/inspection/defects.h"
#include "lfi/inspection/golden_model.h"
#include "lfi/inspection/verdict.h"

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace lfi {

enum class SaveImages { All, Failed, None };
enum class OnDeviceLoss { Stop, Wait };

// [output.mqtt]: where a run publishes its records and state (mqtt_output.h).
struct MqttOutputSettings {
  std::string broker;  // mqtt://host[:port] or mqtts://host[:port]
  std::string host;
  int port = 1883;
  bool tls = false;
  std::string topic;  // the prefix: <topic>/record, <topic>/state
  int qos = 1;
  std::string clientId;                                              // empty: lfi-<host name>-<process id>
  std::filesystem::path credentialsFile, caFile, certFile, keyFile;  // empty: none
  int queueLimit = 1000;
  int keepalive_s = 10;
  double drain_s = 5;
};

// [output.line]: the camera's output line pulsed on a failed part (reject_line.h).
struct LineOutputSettings {
  std::string line = "Line1";
  std::string userOutput = "UserOutput0";
  double pulse_ms = 50;
};

struct BenchFile {
  std::filesystem::path file;  // as given
  double coverageFactor = 2;
  // The calibrated values' expanded uncertainties by "<table>.<key>" ("geometry.distance_mm"), as the file's
  // `<key>_u` give them ([display.response]'s stay with it).
  std::map<std::string, std::vector<double>> uncertainty;
  // [camera]
  DeviceUri cameraUri;
  CameraSettings camera;
  double objectPixel_mm = 0;
  CameraNoise noise;
  int grabTimeout_ms = 5000;
  int retries = 3;
  std::filesystem::path darkFrame, flatFrame;  // empty: none
  // [display]
  DeviceUri displayUri;
  int settle_ms = 0;
  double white = 0;
  std::optional<DisplayOpticsParams> displayOptics;  // [display.optics]
  std::optional<PanelResponseParams> panelResponse;  // [display.response]
  // [capture]: exactly one of the two
  std::optional<DeviceUri> captureUri;
  std::filesystem::path lightFieldFile;
  // [geometry]
  double distance_mm = 0;
  std::optional<Vec2> partCentre_px;                // none: the image's centre
  std::optional<calib::CameraMap> cameraOnDisplay;  // where the camera looks on the display
  std::filesystem::path partModel;                  // the part's model (a scene file); empty: none
  double defectDepth_mm = 0;  // the height in the part's frame at which defects are placed inside it
  // [reference]
  std::filesystem::path referenceFolder;
  int referenceFrames = 16;
  std::optional<double> maskRadius_mm;
  double maskLitFraction = 0.25;
  // [inspection]
  int inspectionFrames = 1;
  double absolute_dn = 0;
  double relative = 6;
  double smallestDefect_mm = 0;
  double closing_mm = 0;
  double minDefectArea_mm2 = 0;
  PassRules rules;
  // [output]
  std::filesystem::path outputFolder;
  SaveImages saveImages = SaveImages::Failed;
  std::optional<MqttOutputSettings> mqtt;  // [output.mqtt]
  std::optional<LineOutputSettings> line;  // [output.line]
  // [run]
  OnDeviceLoss onDeviceLoss = OnDeviceLoss::Stop;
  double waitLimit_s = 60;

  // What the reference depends on, one "key = value" line each, in a fixed
  // order: the devices' URIs, the camera's settings, the capture, the geometry
  // and the mask. Not the inspection's thresholds or rules, nor the output: a
  // reference stays valid when those change. Paths the file gives relative to
  // its folder (sim: scenes, the light field file) are written so, so that a
  // bench moved or copied with its files keeps its hash.
  std::string referenceIdentity() const;
  // A 64-bit FNV-1a hash of referenceIdentity(), 16 hex digits.
  std::string referenceHash() const;
  // The part's frame on an image of the given size: the display calibration's
  // camera map where the bench has one (the camera's rotation, mirroring and
  // per-axis scale), else object_pixel_mm on the image's axes.
  PartFrame partFrame(int width_px, int height_px) const;
  // The detection settings in camera pixels.
  DetectionSettings detection() const;
};

// Reads and checks a bench file. Throws Errc::NotFound for a missing file and
// Errc::Config naming file, line and key for anything else.
BenchFile readBenchFile(const std::filesystem::path& file);

}  // namespace lfi
