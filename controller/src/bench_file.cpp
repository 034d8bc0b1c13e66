// SPDX-License-Identifier: Apache-2.0
#include "lfi/controller/bench_file.h"

#include "lfi/core/config.h"
#include "lfi/core/error.h"
#include "lfi/drivers/device_uri.h"
#include "lfi/drivers/display_calibration_file.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace lfi {

namespace fs = std::filesystem;

namespace {

// A path in the file, relative to the file's folder.
fs::path pathIn(ConfigTable& t, const std::string& key) {
  const std::string text = t.string(key);
  if (text.empty()) fail(Errc::Config, "{} is empty", t.where(key));
  const fs::path p = text;
  return (p.is_absolute() ? p : t.directory() / p).lexically_normal();
}

// A device URI; the path of a sim: URI (a scene file) relative to the file's folder.
DeviceUri uriIn(ConfigTable& t, const std::string& key, const char* kind) {
  DeviceUri uri;
  try {
    uri = DeviceUri::parse(t.string(key), kind, "sim:scene.toml");
  } catch (const Error& e) {
    fail(Errc::Config, "{}: {}", t.where(key), e.what());
  }
  if (uri.scheme == "sim" && !uri.path.empty() && !fs::path(uri.path).is_absolute())
    uri.path = (t.directory() / uri.path).lexically_normal().string();
  return uri;
}

std::optional<double> optionalNumber(ConfigTable& t, const std::string& key, double min, double max) {
  if (!t.has(key)) return std::nullopt;
  return t.number(key, std::nullopt, min, max);
}

// A calibrated value's expanded uncertainty, `<key>_u` beside `key` in [table]: as many numbers as the value
// holds (`count`; a number: 1), each >= 0, kept as "<table>.<key>".
void readUncertainty(ConfigTable& t, const std::string& table, const std::string& key, std::size_t count,
                     BenchFile& b) {
  const std::string u = key + "_u";
  if (!t.has(u)) return;
  if (!t.has(key)) fail(Errc::Config, "{} is the uncertainty of {}, which [{}] does not give", t.where(u), key, table);
  b.uncertainty[table + "." + key] =
      count == 1 ? std::vector<double>{t.number(u, std::nullopt, 0, 1e6)} : t.numbers(u, count, std::nullopt, 0, 1e6);
}

void readCamera(ConfigTable t, BenchFile& b) {
  b.cameraUri = uriIn(t, "uri", "camera");
  CameraSettings& c = b.camera;
  c.exposure_us = t.number("exposure_us", std::nullopt, 1e-3, 1e9);
  c.gain = t.number("gain", 0.0, -1e3, 1e3);
  const std::string format = t.string("pixel_format", "Mono12", {"Mono8", "Mono12", "Mono16"});
  c.pixelFormat = format == "Mono8"    ? PixelFormat::Mono8
                  : format == "Mono16" ? PixelFormat::Mono16
                                       : PixelFormat::Mono12;
  const std::string trigger = t.string("trigger", "software", {"software", "free_run", "line"});
  c.trigger = trigger == "free_run" ? TriggerMode::FreeRun
              : trigger == "line"   ? TriggerMode::Line
                                    : TriggerMode::Software;
  if (t.has("trigger_line") && c.trigger != TriggerMode::Line)
    fail(Errc::Config, "{} is only for trigger = \"line\"", t.where("trigger_line"));
  c.triggerLine = t.string("trigger_line", "Line0");
  if (t.has("frame_rate_hz") && c.trigger != TriggerMode::FreeRun)
    fail(Errc::Config, "{} is only for trigger = \"free_run\"", t.where("frame_rate_hz"));
  c.frameRate_hz = t.number("frame_rate_hz", 0.0, 0, 1e6);
  c.binning = t.integer("binning", 1, 1, 16);
  b.objectPixel_mm = t.number("object_pixel_mm", std::nullopt, 1e-6, 1e3);
  readUncertainty(t, "camera", "object_pixel_mm", 1, b);
  b.noise.read_dn = t.number("read_noise_dn", std::nullopt, 0, 1e6);
  b.noise.gain_dnPerElectron = t.number("dn_per_electron", std::nullopt, 0, 1e6);
  b.grabTimeout_ms = t.integer("grab_timeout_ms", 5000, 1, 86'400'000);
  b.retries = t.integer("retries", 3, 0, 1000);
  if (t.has("dark_frame")) b.darkFrame = pathIn(t, "dark_frame");
  if (t.has("flat_frame")) {
    if (b.darkFrame.empty())
      fail(Errc::Config, "{} needs a dark_frame: a flat frame is corrected by the dark one", t.where("flat_frame"));
    b.flatFrame = pathIn(t, "flat_frame");
  }
  t.finish();
}

// [display.response]: `lfi calibrate panel`'s curves (one, or red, green and blue) and backlight, each with
// its uncertainty (`<key>_u`, the same length, expanded by the file's coverage factor).
PanelResponseParams readPanelResponse(ConfigTable t) {
  PanelResponseParams p;
  p.levels = t.numbers("levels", 2, 256, std::nullopt, 0, 255);
  const bool colours = t.has("red") || t.has("green") || t.has("blue");
  if (colours && t.has("light"))
    fail(Errc::Config, "{}: give light (every subpixel alike) or red, green and blue, not both", t.where("light"));
  const std::vector<std::string> curves =
      colours ? std::vector<std::string>{"red", "green", "blue"} : std::vector<std::string>{"light"};
  for (const std::string& key : curves) {
    p.light.push_back(t.numbers(key, p.levels.size(), std::nullopt, 0, 1));
    t.numbers(key + "_u", p.levels.size(), std::vector<double>{}, 0, 1);
  }
  const std::vector<double> backlight = t.numbers("backlight", 6, std::vector<double>{1, 0, 0, 0, 0, 0}, -1e3, 1e3);
  std::copy(backlight.begin(), backlight.end(), p.backlight.begin());
  t.numbers("backlight_u", 6, std::vector<double>{}, 0, 1e3);
  try {
    PanelResponse::validate(p);
  } catch (const Error& e) {
    fail(Errc::Config, "{}: [display.response]: {}", t.file(), e.what());
  }
  t.finish();
  return p;
}

void readDisplay(ConfigTable t, BenchFile& b) {
  b.displayUri = uriIn(t, "uri", "display");
  b.settle_ms = t.integer("settle_ms", 0, 0, 86'400'000);
  b.white = t.number("white", 0.0, 0, 1e30);
  if (t.has("optics")) {
    ConfigTable optics = t.table("optics");
    if (!optics.has("optics"))
      fail(Errc::Config,
           "{}: [display.optics] names no class: it needs optics = \"lenslet_array\" (or "
           "\"pinhole_array\", \"lenticular\", \"line_barrier\") and every value the class takes",
           t.file());
    b.displayOptics = readDisplayOpticsTable(optics, DisplayOpticsParams{});
    for (const auto& [key, count] : opticsNumberKeys(b.displayOptics->type))
      readUncertainty(optics, "display.optics", key, count, b);
    optics.finish();
    // One place for the display's optics: the table, or a calibration file the URI names, not both.
    if (b.displayUri.find("calibration"))
      fail(Errc::Config,
           "{}: the display's optics are stated twice, by [display.optics] and by the URI's calibration = '{}'; "
           "keep one",
           t.where("uri"), *b.displayUri.find("calibration"));
  }
  if (t.has("response")) b.panelResponse = readPanelResponse(t.table("response"));
  t.finish();
}

void readCapture(ConfigTable t, BenchFile& b) {
  if (t.has("uri") == t.has("light_field"))
    fail(Errc::Config, "{}: [capture] needs exactly one of 'uri' (a capture device) and 'light_field' (a file)",
         t.where(t.has("uri") ? "uri" : "light_field"));
  if (t.has("uri")) {
    b.captureUri = uriIn(t, "uri", "light field capture");
    if (b.captureUri->find("distance_mm"))
      fail(Errc::Config,
           "{}: the capture URI carries distance_mm, but Δ has one place in a bench file: [geometry] distance_mm, "
           "which the capture is handed; delete '{}' from the URI (docs/inspection.md)",
           t.where("uri"), "distance_mm=" + *b.captureUri->find("distance_mm"));
  } else
    b.lightFieldFile = pathIn(t, "light_field");
  t.finish();
}

void readGeometry(ConfigTable t, BenchFile& b) {
  b.distance_mm = t.number("distance_mm", std::nullopt, 0, 1e6);
  if (t.has("part_centre_px")) {
    const auto c = t.numbers("part_centre_px", 2, std::nullopt, -1e6, 1e6);
    b.partCentre_px = Vec2(c[0], c[1]);
  }
  if (t.has("display_per_pixel_mm") != t.has("display_at_image_centre_mm"))
    fail(Errc::Config, "{} needs display_per_pixel_mm and display_at_image_centre_mm together",
         t.where(t.has("display_per_pixel_mm") ? "display_per_pixel_mm" : "display_at_image_centre_mm"));
  if (t.has("display_per_pixel_mm")) {
    const auto a = t.numbers("display_per_pixel_mm", 4, std::nullopt, -1e3, 1e3);
    const auto c = t.numbers("display_at_image_centre_mm", 2, std::nullopt, -1e6, 1e6);
    calib::CameraMap m{cv::Matx22d(a[0], a[1], a[2], a[3]), Vec2(c[0], c[1])};
    if (!(std::abs(cv::determinant(m.perPixel_mm)) > 0))
      fail(Errc::Config, "{} = [{}, {}, {}, {}] maps the image onto a line", t.where("display_per_pixel_mm"), a[0],
           a[1], a[2], a[3]);
    b.cameraOnDisplay = m;
  }
  if (t.has("part_model")) b.partModel = pathIn(t, "part_model");
  if (t.has("defect_depth_mm") && b.partModel.empty())
    fail(Errc::Config, "{} places defects inside the part's model: it needs part_model", t.where("defect_depth_mm"));
  b.defectDepth_mm = t.number("defect_depth_mm", 0.0, -1e4, 1e4);
  readUncertainty(t, "geometry", "distance_mm", 1, b);
  readUncertainty(t, "geometry", "part_centre_px", 2, b);
  readUncertainty(t, "geometry", "display_per_pixel_mm", 4, b);
  readUncertainty(t, "geometry", "display_at_image_centre_mm", 2, b);
  t.finish();
}

void readReference(ConfigTable t, BenchFile& b) {
  b.referenceFolder = pathIn(t, "folder");
  b.referenceFrames = t.integer("frames", 16, 1, 100000);
  b.maskRadius_mm = optionalNumber(t, "mask_radius_mm", 0, 1e6);
  b.maskLitFraction = t.number("mask_lit_fraction", 0.25, 0, 1);
  t.finish();
}

void readInspection(ConfigTable t, BenchFile& b) {
  b.inspectionFrames = t.integer("frames", 1, 1, 100000);
  b.absolute_dn = t.number("absolute_dn", 0.0, 0, 1e9);
  b.relative = t.number("relative", 6.0, 0, 1e6);
  b.smallestDefect_mm = t.number("smallest_defect_mm", 0.0, 0, 1e6);
  b.closing_mm = t.number("closing_mm", 0.0, 0, 1e6);
  b.minDefectArea_mm2 = t.number("min_defect_area_mm2", 0.0, 0, 1e12);
  b.rules.maxDefects = t.integer("max_defects", 0, 0, 1 << 30);
  b.rules.maxDefectArea_mm2 = optionalNumber(t, "max_defect_area_mm2", 0, 1e12);
  b.rules.maxTotalArea_mm2 = optionalNumber(t, "max_total_area_mm2", 0, 1e12);
  t.finish();
  // The same limits in camera pixels (findDefects'): named here, not at the first part.
  const DetectionSettings d = b.detection();
  if (d.smoothing_px > 100 || d.closing_px > 100)
    fail(Errc::Config,
         "{}: smallest_defect_mm = {} and closing_mm = {} are {:.3g} and {} camera pixels of {} mm; "
         "at most 400 and 100",
         t.file(), b.smallestDefect_mm, b.closing_mm, 4 * d.smoothing_px, d.closing_px, b.objectPixel_mm);
}

// [output.mqtt]. The broker's secrets stay in files of their own (credentials_file, key_file), never here.
MqttOutputSettings readMqtt(ConfigTable t) {
  t.requireKnownKeys({"broker", "topic", "qos", "client_id", "credentials_file", "ca_file", "cert_file", "key_file",
                      "queue_limit", "keepalive_s", "drain_s"});
  MqttOutputSettings m;
  m.broker = t.string("broker");
  const auto scheme = m.broker.find("://");
  const std::string kind = scheme == std::string::npos ? "" : m.broker.substr(0, scheme);
  if (kind != "mqtt" && kind != "mqtts")
    fail(Errc::Config, "{}: '{}' is not mqtt://host[:port] or mqtts://host[:port]", t.where("broker"), m.broker);
  m.tls = kind == "mqtts";
  m.port = m.tls ? 8883 : 1883;
  std::string rest = m.broker.substr(scheme + 3);
  if (!rest.empty() && rest.back() == '/') rest.pop_back();
  const auto colon = rest.rfind(':');
  m.host = rest.substr(0, colon);
  if (colon != std::string::npos) {
    const std::string port = rest.substr(colon + 1);
    char* end = nullptr;
    const long value = std::strtol(port.c_str(), &end, 10);
    if (port.empty() || *end != '\0' || value < 1 || value > 65535)
      fail(Errc::Config, "{}: '{}' is not a port (1 to 65535)", t.where("broker"), port);
    m.port = static_cast<int>(value);
  }
  if (m.host.empty() || m.host.find_first_of("/@?# ") != std::string::npos)
    fail(Errc::Config, "{}: '{}' names no host (mqtt://host[:port])", t.where("broker"), m.broker);
  m.topic = t.string("topic");
  if (m.topic.empty() || m.topic.find_first_of("+#") != std::string::npos || m.topic.back() == '/')
    fail(Errc::Config, "{}: '{}' is not a topic prefix (not empty, no wildcards + or #, no trailing /)",
         t.where("topic"), m.topic);
  m.qos = t.integer("qos", 1, 0, 2);
  m.clientId = t.string("client_id", "");
  if (t.has("credentials_file")) m.credentialsFile = pathIn(t, "credentials_file");
  if (t.has("ca_file")) m.caFile = pathIn(t, "ca_file");
  if (t.has("cert_file")) m.certFile = pathIn(t, "cert_file");
  if (t.has("key_file")) m.keyFile = pathIn(t, "key_file");
  if (m.certFile.empty() != m.keyFile.empty())
    fail(Errc::Config, "{}: cert_file and key_file go together (the client's certificate and its key)", t.file());
  if (!m.tls && (!m.caFile.empty() || !m.certFile.empty()))
    fail(Errc::Config, "{}: ca_file, cert_file and key_file need an mqtts:// broker", t.where("broker"));
  m.queueLimit = t.integer("queue_limit", 1000, 1, 1'000'000);
  m.keepalive_s = t.integer("keepalive_s", 10, 5, 3600);
  m.drain_s = t.number("drain_s", 5.0, 0, 3600);
  t.finish();
  return m;
}

LineOutputSettings readLine(ConfigTable t) {
  t.requireKnownKeys({"line", "user_output", "pulse_ms"});
  LineOutputSettings l;
  l.line = t.string("line", l.line);
  l.userOutput = t.string("user_output", l.userOutput);
  for (const auto& [key, value] : {std::pair{"line", l.line}, std::pair{"user_output", l.userOutput}})
    if (value.empty()) fail(Errc::Config, "{} is empty", t.where(key));
  l.pulse_ms = t.number("pulse_ms", l.pulse_ms, 1, 10'000);
  t.finish();
  return l;
}

void readOutput(ConfigTable t, BenchFile& b) {
  b.outputFolder = pathIn(t, "folder");
  const std::string save = t.string("save_images", "failed", {"all", "failed", "none"});
  b.saveImages = save == "all" ? SaveImages::All : save == "none" ? SaveImages::None : SaveImages::Failed;
  if (t.has("mqtt")) b.mqtt = readMqtt(t.table("mqtt"));
  if (t.has("line")) b.line = readLine(t.table("line"));
  t.finish();
}

void readRun(ConfigTable t, BenchFile& b) {
  b.onDeviceLoss =
      t.string("on_device_loss", "stop", {"stop", "wait"}) == "wait" ? OnDeviceLoss::Wait : OnDeviceLoss::Stop;
  b.waitLimit_s = t.number("wait_limit_s", 60.0, 0, 86400.0 * 365);
  t.finish();
}

// A path of the file's (made from its folder by pathIn or uriIn) as seen from
// that folder, so that a bench moved with its files keeps its reference hash;
// an absolute path given in the file stays absolute.
std::string fromBenchFolder(const fs::path& benchFile, const fs::path& path) {
  const fs::path relative = path.lexically_relative(benchFile.parent_path());
  return relative.empty() ? path.string() : relative.string();
}

std::string portableUri(const fs::path& benchFile, const DeviceUri& uri) {
  if (uri.scheme != "sim") return uri.text();
  DeviceUri portable = uri;
  portable.path = fromBenchFolder(benchFile, uri.path);
  return portable.text();
}

}  // namespace

BenchFile readBenchFile(const fs::path& file) {
  ConfigTable root = ConfigTable::parseFile(file);
  root.requireKnownKeys({"format", "version", "coverage_factor", "camera", "display", "capture", "geometry",
                         "reference", "inspection", "output", "run"});
  root.string("format", std::nullopt, {"lfi-inspection-bench"});
  root.integer("version", std::nullopt, 1, 1);
  BenchFile b;
  b.file = file;
  b.coverageFactor = root.number("coverage_factor", 2.0, 1, 10);
  const auto table = [&](const char* name, const std::vector<std::string>& keys, bool required) {
    if (!required && !root.has(name)) return std::optional<ConfigTable>();
    if (!root.has(name)) fail(Errc::Config, "{}: the table [{}] is missing", file.string(), name);
    ConfigTable t = root.table(name);
    t.requireKnownKeys(keys);
    return std::optional<ConfigTable>(std::move(t));
  };
  readCamera(*table("camera",
                    {"uri", "exposure_us", "gain", "pixel_format", "trigger", "trigger_line", "frame_rate_hz",
                     "binning", "object_pixel_mm", "object_pixel_mm_u", "read_noise_dn", "dn_per_electron",
                     "grab_timeout_ms", "retries", "dark_frame", "flat_frame"},
                    true),
             b);
  readDisplay(*table("display", {"uri", "settle_ms", "white", "optics", "response"}, true), b);
  readCapture(*table("capture", {"uri", "light_field"}, true), b);
  readGeometry(*table("geometry",
                      {"distance_mm", "distance_mm_u", "part_centre_px", "part_centre_px_u", "display_per_pixel_mm",
                       "display_per_pixel_mm_u", "display_at_image_centre_mm", "display_at_image_centre_mm_u",
                       "part_model", "defect_depth_mm"},
                      true),
               b);
  readReference(*table("reference", {"folder", "frames", "mask_radius_mm", "mask_lit_fraction"}, true), b);
  if (auto t = table("inspection",
                     {"frames", "absolute_dn", "relative", "smallest_defect_mm", "closing_mm", "min_defect_area_mm2",
                      "max_defects", "max_defect_area_mm2", "max_total_area_mm2"},
                     false))
    readInspection(*t, b);
  readOutput(*table("output", {"folder", "save_images", "mqtt", "line"}, true), b);
  if (auto t = table("run", {"on_device_loss", "wait_limit_s"}, false)) readRun(*t, b);
  root.finish();
  return b;
}

namespace {

// The optics override in one line (absent from the identity of a bench without it, whose hash stays).
std::string opticsIdentity(const std::optional<DisplayOpticsParams>& o) {
  if (!o) return "";
  return fmt::format(
      "display.optics = {} {} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} "
      "{:.17g} {:.17g} {:.17g}\n",
      toString(o->type), toString(o->packing), o->lensPitch_px, o->slant_rad, o->offset_px, o->arrayPitch_mm,
      o->rotation_rad, o->arrayOffsetX_mm, o->arrayOffsetY_mm, o->fillFactor, o->pinholeDiameter_mm, o->gap_mm,
      o->focalLength_mm, o->slitWidth_mm);
}

}  // namespace

std::string BenchFile::referenceIdentity() const {
  // What corrects the camera's images and drives the panel (absent from the identity of a bench without it).
  std::string calibrated;
  if (!darkFrame.empty()) calibrated += "camera.dark_frame = " + fromBenchFolder(file, darkFrame) + "\n";
  if (!flatFrame.empty()) calibrated += "camera.flat_frame = " + fromBenchFolder(file, flatFrame) + "\n";
  if (panelResponse) {
    calibrated += fmt::format("display.response = {:.17g} |", fmt::join(panelResponse->levels, " "));
    for (const auto& curve : panelResponse->light) calibrated += fmt::format(" {:.17g} |", fmt::join(curve, " "));
    calibrated += fmt::format(" {:.17g}\n", fmt::join(panelResponse->backlight, " "));
  }
  // (%.17g: a number reads back as the same double, so equal settings give equal text.)
  return opticsIdentity(displayOptics) + calibrated +
         fmt::format(
             "camera.uri = {}\ncamera.exposure_us = {:.17g}\ncamera.gain = {:.17g}\ncamera.pixel_format = {}\n"
             "camera.binning = {}\ncamera.object_pixel_mm = {:.17g}\ndisplay.uri = {}\ndisplay.white = {:.17g}\n"
             "capture.uri = {}\ncapture.light_field = {}\ngeometry.distance_mm = {:.17g}\ngeometry.part_centre_px = "
             "{}\n"
             "reference.mask_radius_mm = {}\nreference.mask_lit_fraction = {:.17g}\n",
             portableUri(file, cameraUri), camera.exposure_us, camera.gain, toString(camera.pixelFormat),
             camera.binning, objectPixel_mm, portableUri(file, displayUri), white,
             captureUri ? portableUri(file, *captureUri) : "",
             lightFieldFile.empty() ? "" : fromBenchFolder(file, lightFieldFile), distance_mm,
             partCentre_px ? fmt::format("[{:.17g}, {:.17g}]", partCentre_px->x, partCentre_px->y) : "centre",
             maskRadius_mm ? fmt::format("{:.17g}", *maskRadius_mm) : "none", maskLitFraction);
}

std::string BenchFile::referenceHash() const {
  std::uint64_t h = 14695981039346656037ull;  // FNV-1a, 64 bits
  for (const unsigned char c : referenceIdentity()) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return fmt::format("{:016x}", h);
}

PartFrame BenchFile::partFrame(int width_px, int height_px) const {
  const Vec2 origin = partCentre_px.value_or(Vec2((width_px - 1) / 2.0, (height_px - 1) / 2.0));
  PartFrame frame =
      cameraOnDisplay ? PartFrame{cameraOnDisplay->perPixel_mm, origin} : PartFrame::isotropic(objectPixel_mm, origin);
  if (const auto a = uncertainty.find("geometry.display_per_pixel_mm"); cameraOnDisplay && a != uncertainty.end())
    frame.perPixelU_mm = cv::Matx22d(a->second[0], a->second[1], a->second[2], a->second[3]);
  else if (const auto s = uncertainty.find("camera.object_pixel_mm"); !cameraOnDisplay && s != uncertainty.end())
    frame.perPixelU_mm = cv::Matx22d(s->second[0], 0, 0, s->second[0]);
  if (const auto o = uncertainty.find("geometry.part_centre_px"); partCentre_px && o != uncertainty.end())
    frame.originU_px = Vec2(o->second[0], o->second[1]);
  frame.centroidU_px = coverageFactor / std::sqrt(12.0);
  return frame;
}

DetectionSettings BenchFile::detection() const {
  DetectionSettings d;
  d.absolute_dn = absolute_dn;
  d.relative = relative;
  // A disc of diameter d has a standard deviation of d / 4 along each axis: the matched Gaussian's.
  d.smoothing_px = smallestDefect_mm / 4 / objectPixel_mm;
  d.closing_px = static_cast<int>(std::lround(closing_mm / objectPixel_mm));
  const double minArea_px = std::ceil(minDefectArea_mm2 / (objectPixel_mm * objectPixel_mm) - 1e-9);
  d.minArea_px = static_cast<int>(std::clamp(minArea_px, 1.0, 1e9));
  return d;
}

}  // namespace lfi
