// SPDX-License-Identifier: Apache-2.0
// The served camera's GenICam description (served_camera_device.h): Aravis's
// fake camera's, with SFNC's digital outputs added.
#include "served_camera_device.h"

#include "lfi/core/error.h"

#include <string>

namespace lfi::emulation::detail {
namespace {

std::string intReg(const char* name, unsigned address, const char* index = nullptr) {
  return std::string("<IntReg Name=\"") + name + "\" NameSpace=\"Custom\"><Address>" + std::to_string(address) +
         "</Address>" + (index ? std::string("<pIndex Offset=\"4\">") + index + "</pIndex>" : "") +
         "<Length>4</Length><AccessMode>RW</AccessMode><pPort>Device</pPort><Sign>Unsigned</Sign>"
         "<Endianess>BigEndian</Endianess></IntReg>\n";
}

std::string enumeration(const char* name, const char* value, std::initializer_list<const char*> entries) {
  std::string xml = std::string("<Enumeration Name=\"") + name + "\" NameSpace=\"Standard\">";
  int i = 0;
  for (const char* entry : entries)
    xml += std::string("<EnumEntry Name=\"") + entry + "\" NameSpace=\"Standard\"><Value>" + std::to_string(i++) +
           "</Value></EnumEntry>";
  return xml + "<pValue>" + value + "</pValue></Enumeration>\n";
}

}  // namespace

std::string servedGenicamXml(const std::string& fakeCameraXml) {
  // SFNC's DigitalIOControl: LineSelector picks a line, whose LineMode and
  // LineSource it indexes; UserOutputSelector picks the user output whose
  // UserOutputValue a line with LineSource = UserOutput<n> shows.
  std::string io =
      "<Category Name=\"DigitalIOControl\" NameSpace=\"Standard\">"
      "<pFeature>LineSelector</pFeature><pFeature>LineMode</pFeature><pFeature>LineSource</pFeature>"
      "<pFeature>UserOutputSelector</pFeature><pFeature>UserOutputValue</pFeature></Category>\n";
  io += enumeration("LineSelector", "LineSelectorRegister", {"Line0", "Line1", "Line2"});
  io += intReg("LineSelectorRegister", kLineSelectorRegister);
  io += enumeration("LineMode", "LineModeRegister", {"Input", "Output"});
  io += intReg("LineModeRegister", kLineModeRegister, "LineSelectorRegister");
  io += enumeration("LineSource", "LineSourceRegister", {"Off", "UserOutput0", "UserOutput1", "UserOutput2"});
  io += intReg("LineSourceRegister", kLineSourceRegister, "LineSelectorRegister");
  io += enumeration("UserOutputSelector", "UserOutputSelectorRegister", {"UserOutput0", "UserOutput1", "UserOutput2"});
  io += intReg("UserOutputSelectorRegister", kUserOutputSelectorRegister);
  io +=
      "<Boolean Name=\"UserOutputValue\" NameSpace=\"Standard\"><pValue>UserOutputValueRegister</pValue>"
      "<OnValue>1</OnValue><OffValue>0</OffValue></Boolean>\n";
  io += intReg("UserOutputValueRegister", kUserOutputValueRegister, "UserOutputSelectorRegister");

  std::string xml = fakeCameraXml;
  const std::string root = "<pFeature>DeviceControl</pFeature>";
  const auto inRoot = xml.find(root);
  const auto end = xml.rfind("</RegisterDescription>");
  if (inRoot == std::string::npos || end == std::string::npos)
    fail(Errc::Device, "served camera: Aravis's fake camera description has no Root category or no end");
  xml.insert(end, io);
  xml.insert(inRoot + root.size(), "<pFeature>DigitalIOControl</pFeature>");
  return xml;
}

}  // namespace lfi::emulation::detail
