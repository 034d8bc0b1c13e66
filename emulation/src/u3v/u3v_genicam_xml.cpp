// SPDX-License-Identifier: Apache-2.0
// The emulated USB3 Vision camera's GenICam XML (GenApi schema 1.1), the file
// its manifest table points at. It maps SFNC features onto the camera
// registers of u3v_registers.h (absolute addresses, little-endian, one port
// "Device", nothing cached: the device changes WidthMax, PayloadSize and the
// like by itself); the bootstrap registers are described only for the ABRM
// strings. Keep the addresses, enumeration values and ranges in step with
// u3v_registers.h.

#include "u3v_registers.h"

namespace lfi::emulation::u3v {

const std::string_view kGenicamXml = R"xml(<?xml version="1.0" encoding="utf-8"?>
<RegisterDescription
  ModelName="LfiU3vCamera"
  VendorName="lfi"
  StandardNameSpace="None"
  SchemaMajorVersion="1"
  SchemaMinorVersion="1"
  SchemaSubMinorVersion="0"
  MajorVersion="1"
  MinorVersion="0"
  SubMinorVersion="0"
  ToolTip="Emulated USB3 Vision camera"
  ProductGuid="e9062ea1-3db3-4a0a-8bd2-2338af931f96"
  VersionGuid="8ed8ce1d-45ad-492c-aee2-37a97caf8673"
  xmlns="http://www.genicam.org/GenApi/Version_1_1"
  xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
  xsi:schemaLocation="http://www.genicam.org/GenApi/Version_1_1
    http://www.genicam.org/GenApi/GenApiSchema_Version_1_1.xsd">

  <Category Name="Root" NameSpace="Standard">
    <pFeature>DeviceControl</pFeature>
    <pFeature>ImageFormatControl</pFeature>
    <pFeature>AcquisitionControl</pFeature>
    <pFeature>AnalogControl</pFeature>
    <pFeature>DigitalIOControl</pFeature>
    <pFeature>TransportLayerControl</pFeature>
  </Category>

  <!-- Device control: the ABRM strings, reset, link throughput -->

  <Category Name="DeviceControl" NameSpace="Standard">
    <pFeature>DeviceVendorName</pFeature>
    <pFeature>DeviceModelName</pFeature>
    <pFeature>DeviceFamilyName</pFeature>
    <pFeature>DeviceVersion</pFeature>
    <pFeature>DeviceManufacturerInfo</pFeature>
    <pFeature>DeviceSerialNumber</pFeature>
    <pFeature>DeviceUserID</pFeature>
    <pFeature>DeviceLinkThroughputLimit</pFeature>
    <pFeature>DeviceReset</pFeature>
  </Category>

  <StringReg Name="DeviceVendorName" NameSpace="Standard"><ToolTip>Manufacturer name.</ToolTip>
    <Address>0x0004</Address><Length>64</Length><AccessMode>RO</AccessMode><pPort>Device</pPort>
    <Cachable>NoCache</Cachable></StringReg>
  <StringReg Name="DeviceModelName" NameSpace="Standard"><ToolTip>Model name.</ToolTip>
    <Address>0x0044</Address><Length>64</Length><AccessMode>RO</AccessMode><pPort>Device</pPort>
    <Cachable>NoCache</Cachable></StringReg>
  <StringReg Name="DeviceFamilyName" NameSpace="Standard"><ToolTip>Family name.</ToolTip>
    <Address>0x0084</Address><Length>64</Length><AccessMode>RO</AccessMode><pPort>Device</pPort>
    <Cachable>NoCache</Cachable></StringReg>
  <StringReg Name="DeviceVersion" NameSpace="Standard"><ToolTip>Device version.</ToolTip>
    <Address>0x00C4</Address><Length>64</Length><AccessMode>RO</AccessMode><pPort>Device</pPort>
    <Cachable>NoCache</Cachable></StringReg>
  <StringReg Name="DeviceManufacturerInfo" NameSpace="Standard"><ToolTip>Manufacturer information.</ToolTip>
    <Address>0x0104</Address><Length>64</Length><AccessMode>RO</AccessMode><pPort>Device</pPort>
    <Cachable>NoCache</Cachable></StringReg>
  <StringReg Name="DeviceSerialNumber" NameSpace="Standard"><ToolTip>Serial number.</ToolTip>
    <Address>0x0144</Address><Length>64</Length><AccessMode>RO</AccessMode><pPort>Device</pPort>
    <Cachable>NoCache</Cachable></StringReg>
  <StringReg Name="DeviceUserID" NameSpace="Standard"><ToolTip>User-defined name.</ToolTip>
    <Address>0x0184</Address><Length>64</Length><AccessMode>RW</AccessMode><pPort>Device</pPort>
    <Cachable>NoCache</Cachable></StringReg>

  <Integer Name="DeviceLinkThroughputLimit" NameSpace="Standard">
    <ToolTip>Link bandwidth limit, in bytes per second.</ToolTip>
    <pValue>DeviceLinkThroughputLimitReg</pValue><Min>1</Min><Max>500000000</Max><Unit>Bps</Unit>
  </Integer>
  <IntReg Name="DeviceLinkThroughputLimitReg"><Address>0x100074</Address><Length>4</Length><AccessMode>RW</AccessMode>
    <pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>LittleEndian</Endianess></IntReg>

  <Command Name="DeviceReset" NameSpace="Standard"><ToolTip>Resets the device.</ToolTip>
    <pValue>DeviceResetReg</pValue><CommandValue>1</CommandValue></Command>
  <IntReg Name="DeviceResetReg"><Address>0x100078</Address><Length>4</Length><AccessMode>WO</AccessMode>
    <pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>LittleEndian</Endianess></IntReg>

  <!-- Image format control -->

  <Category Name="ImageFormatControl" NameSpace="Standard">
    <pFeature>SensorWidth</pFeature>
    <pFeature>SensorHeight</pFeature>
    <pFeature>WidthMax</pFeature>
    <pFeature>HeightMax</pFeature>
    <pFeature>Width</pFeature>
    <pFeature>Height</pFeature>
    <pFeature>OffsetX</pFeature>
    <pFeature>OffsetY</pFeature>
    <pFeature>BinningHorizontal</pFeature>
    <pFeature>BinningVertical</pFeature>
    <pFeature>PixelFormat</pFeature>
  </Category>

  <Integer Name="SensorWidth" NameSpace="Standard"><ToolTip>Sensor width, in pixels.</ToolTip>
    <pValue>SensorWidthReg</pValue></Integer>
  <IntReg Name="SensorWidthReg"><Address>0x10001C</Address><Length>4</Length><AccessMode>RO</AccessMode>
    <pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>LittleEndian</Endianess></IntReg>

  <Integer Name="SensorHeight" NameSpace="Standard"><ToolTip>Sensor height, in pixels.</ToolTip>
    <pValue>SensorHeightReg</pValue></Integer>
  <IntReg Name="SensorHeightReg"><Address>0x100020</Address><Length>4</Length><AccessMode>RO</AccessMode>
    <pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>LittleEndian</Endianess></IntReg>

  <Integer Name="WidthMax" NameSpace="Standard"><ToolTip>Maximum image width, after binning.</ToolTip>
    <pValue>WidthMaxReg</pValue></Integer>
  <IntReg Name="WidthMaxReg"><Address>0x100024</Address><Length>4</Length><AccessMode>RO</AccessMode>
    <pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>LittleEndian</Endianess></IntReg>

  <Integer Name="HeightMax" NameSpace="Standard"><ToolTip>Maximum image height, after binning.</ToolTip>
    <pValue>HeightMaxReg</pValue></Integer>
  <IntReg Name="HeightMaxReg"><Address>0x100028</Address><Length>4</Length><AccessMode>RO</AccessMode>
    <pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>LittleEndian</Endianess></IntReg>

  <Integer Name="Width" NameSpace="Standard"><ToolTip>Image width, in pixels.</ToolTip>
    <pValue>WidthReg</pValue><Min>1</Min><pMax>WidthMax</pMax><Inc>1</Inc></Integer>
  <IntReg Name="WidthReg"><Address>0x100000</Address><Length>4</Length><AccessMode>RW</AccessMode>
    <pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>LittleEndian</Endianess></IntReg>

  <Integer Name="Height" NameSpace="Standard"><ToolTip>Image height, in pixels.</ToolTip>
    <pValue>HeightReg</pValue><Min>1</Min><pMax>HeightMax</pMax><Inc>1</Inc></Integer>
  <IntReg Name="HeightReg"><Address>0x100004</Address><Length>4</Length><AccessMode>RW</AccessMode>
    <pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>LittleEndian</Endianess></IntReg>

  <Integer Name="OffsetX" NameSpace="Standard"><ToolTip>Horizontal offset of the image, in pixels.</ToolTip>
    <pValue>OffsetXReg</pValue><Min>0</Min><pMax>OffsetXMax</pMax><Inc>1</Inc></Integer>
  <IntSwissKnife Name="OffsetXMax"><pVariable Name="WMAX">WidthMax</pVariable><pVariable Name="W">Width</pVariable>
    <Formula>WMAX - W</Formula></IntSwissKnife>
  <IntReg Name="OffsetXReg"><Address>0x100008</Address><Length>4</Length><AccessMode>RW</AccessMode>
    <pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>LittleEndian</Endianess></IntReg>

  <Integer Name="OffsetY" NameSpace="Standard"><ToolTip>Vertical offset of the image, in pixels.</ToolTip>
    <pValue>OffsetYReg</pValue><Min>0</Min><pMax>OffsetYMax</pMax><Inc>1</Inc></Integer>
  <IntSwissKnife Name="OffsetYMax"><pVariable Name="HMAX">HeightMax</pVariable><pVariable Name="H">Height</pVariable>
    <Formula>HMAX - H</Formula></IntSwissKnife>
  <IntReg Name="OffsetYReg"><Address>0x10000C</Address><Length>4</Length><AccessMode>RW</AccessMode>
    <pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>LittleEndian</Endianess></IntReg>

  <Integer Name="BinningHorizontal" NameSpace="Standard"><ToolTip>Horizontal binning factor.</ToolTip>
    <pValue>BinningHorizontalReg</pValue><Min>1</Min><Max>8</Max><Inc>1</Inc></Integer>
  <IntReg Name="BinningHorizontalReg"><Address>0x100014</Address><Length>4</Length><AccessMode>RW</AccessMode>
    <pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>LittleEndian</Endianess></IntReg>

  <Integer Name="BinningVertical" NameSpace="Standard"><ToolTip>Vertical binning factor.</ToolTip>
    <pValue>BinningVerticalReg</pValue><Min>1</Min><Max>8</Max><Inc>1</Inc></Integer>
  <IntReg Name="BinningVerticalReg"><Address>0x100018</Address><Length>4</Length><AccessMode>RW</AccessMode>
    <pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>LittleEndian</Endianess></IntReg>

  <Enumeration Name="PixelFormat" NameSpace="Standard">
    <ToolTip>Pixel format (PFNC code).</ToolTip>
    <EnumEntry Name="Mono8" NameSpace="Standard"><Value>0x01080001</Value></EnumEntry>
    <EnumEntry Name="Mono12" NameSpace="Standard"><Value>0x01100005</Value></EnumEntry>
    <EnumEntry Name="Mono12p" NameSpace="Standard"><Value>0x010C0047</Value></EnumEntry>
    <EnumEntry Name="Mono16" NameSpace="Standard"><Value>0x01100007</Value></EnumEntry>
    <pValue>PixelFormatReg</pValue>
  </Enumeration>
  <IntReg Name="PixelFormatReg"><Address>0x100010</Address><Length>4</Length><AccessMode>RW</AccessMode>
    <pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>LittleEndian</Endianess></IntReg>

  <!-- Acquisition control -->

  <Category Name="AcquisitionControl" NameSpace="Standard">
    <pFeature>AcquisitionMode</pFeature>
    <pFeature>AcquisitionStart</pFeature>
    <pFeature>AcquisitionStop</pFeature>
    <pFeature>AcquisitionFrameCount</pFeature>
    <pFeature>AcquisitionFrameRate</pFeature>
    <pFeature>TriggerSelector</pFeature>
    <pFeature>TriggerMode</pFeature>
    <pFeature>TriggerSource</pFeature>
    <pFeature>TriggerSoftware</pFeature>
    <pFeature>ExposureTime</pFeature>
  </Category>

  <Enumeration Name="AcquisitionMode" NameSpace="Standard">
    <ToolTip>Acquisition mode.</ToolTip>
    <EnumEntry Name="Continuous" NameSpace="Standard"><Value>0</Value></EnumEntry>
    <EnumEntry Name="SingleFrame" NameSpace="Standard"><Value>1</Value></EnumEntry>
    <EnumEntry Name="MultiFrame" NameSpace="Standard"><Value>2</Value></EnumEntry>
    <pValue>AcquisitionModeReg</pValue>
  </Enumeration>
  <IntReg Name="AcquisitionModeReg"><Address>0x100030</Address><Length>4</Length><AccessMode>RW</AccessMode>
    <pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>LittleEndian</Endianess></IntReg>

  <Command Name="AcquisitionStart" NameSpace="Standard"><ToolTip>Starts the acquisition.</ToolTip>
    <pValue>AcquisitionStartReg</pValue><CommandValue>1</CommandValue></Command>
  <IntReg Name="AcquisitionStartReg"><Address>0x100034</Address><Length>4</Length><AccessMode>WO</AccessMode>
    <pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>LittleEndian</Endianess></IntReg>

  <Command Name="AcquisitionStop" NameSpace="Standard"><ToolTip>Stops the acquisition.</ToolTip>
    <pValue>AcquisitionStopReg</pValue><CommandValue>1</CommandValue></Command>
  <IntReg Name="AcquisitionStopReg"><Address>0x100038</Address><Length>4</Length><AccessMode>WO</AccessMode>
    <pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>LittleEndian</Endianess></IntReg>

  <Integer Name="AcquisitionFrameCount" NameSpace="Standard">
    <ToolTip>Number of frames to acquire in MultiFrame mode.</ToolTip>
    <pValue>AcquisitionFrameCountReg</pValue><Min>1</Min><Max>65535</Max><Inc>1</Inc></Integer>
  <IntReg Name="AcquisitionFrameCountReg"><Address>0x100058</Address><Length>4</Length><AccessMode>RW</AccessMode>
    <pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>LittleEndian</Endianess></IntReg>

  <Float Name="AcquisitionFrameRate" NameSpace="Standard"><ToolTip>Frame rate, in Hz.</ToolTip>
    <pValue>AcquisitionFrameRateReg</pValue><Min>0.001</Min><Max>1000</Max><Unit>Hz</Unit></Float>
  <FloatReg Name="AcquisitionFrameRateReg"><Address>0x100054</Address><Length>4</Length><AccessMode>RW</AccessMode>
    <pPort>Device</pPort><Cachable>NoCache</Cachable><Endianess>LittleEndian</Endianess></FloatReg>

  <Enumeration Name="TriggerSelector" NameSpace="Standard">
    <ToolTip>Trigger that the trigger features configure.</ToolTip>
    <EnumEntry Name="FrameStart" NameSpace="Standard"><Value>0</Value></EnumEntry>
    <pValue>TriggerSelectorReg</pValue>
    <pSelected>TriggerMode</pSelected>
    <pSelected>TriggerSource</pSelected>
    <pSelected>TriggerSoftware</pSelected>
  </Enumeration>
  <IntReg Name="TriggerSelectorReg"><Address>0x10003C</Address><Length>4</Length><AccessMode>RW</AccessMode>
    <pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>LittleEndian</Endianess></IntReg>

  <Enumeration Name="TriggerMode" NameSpace="Standard">
    <ToolTip>Whether the selected trigger is active.</ToolTip>
    <EnumEntry Name="Off" NameSpace="Standard"><Value>0</Value></EnumEntry>
    <EnumEntry Name="On" NameSpace="Standard"><Value>1</Value></EnumEntry>
    <pValue>TriggerModeReg</pValue>
  </Enumeration>
  <IntReg Name="TriggerModeReg"><Address>0x100040</Address><Length>4</Length><AccessMode>RW</AccessMode>
    <pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>LittleEndian</Endianess></IntReg>

  <Enumeration Name="TriggerSource" NameSpace="Standard">
    <ToolTip>Source of the selected trigger.</ToolTip>
    <EnumEntry Name="Software" NameSpace="Standard"><Value>0</Value></EnumEntry>
    <EnumEntry Name="Line0" NameSpace="Standard"><Value>1</Value></EnumEntry>
    <EnumEntry Name="Line1" NameSpace="Standard"><Value>2</Value></EnumEntry>
    <pValue>TriggerSourceReg</pValue>
  </Enumeration>
  <IntReg Name="TriggerSourceReg"><Address>0x100044</Address><Length>4</Length><AccessMode>RW</AccessMode>
    <pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>LittleEndian</Endianess></IntReg>

  <Command Name="TriggerSoftware" NameSpace="Standard"><ToolTip>Fires the selected trigger.</ToolTip>
    <pValue>TriggerSoftwareReg</pValue><CommandValue>1</CommandValue></Command>
  <IntReg Name="TriggerSoftwareReg"><Address>0x100048</Address><Length>4</Length><AccessMode>WO</AccessMode>
    <pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>LittleEndian</Endianess></IntReg>

  <Float Name="ExposureTime" NameSpace="Standard"><ToolTip>Exposure time, in microseconds.</ToolTip>
    <pValue>ExposureTimeReg</pValue><Min>1</Min><Max>10000000</Max><Unit>us</Unit></Float>
  <FloatReg Name="ExposureTimeReg"><Address>0x10004C</Address><Length>4</Length><AccessMode>RW</AccessMode>
    <pPort>Device</pPort><Cachable>NoCache</Cachable><Endianess>LittleEndian</Endianess></FloatReg>

  <!-- Analog control -->

  <Category Name="AnalogControl" NameSpace="Standard">
    <pFeature>Gain</pFeature>
  </Category>

  <Float Name="Gain" NameSpace="Standard"><ToolTip>Gain, in dB.</ToolTip>
    <pValue>GainReg</pValue><Min>0</Min><Max>24</Max><Unit>dB</Unit></Float>
  <FloatReg Name="GainReg"><Address>0x100050</Address><Length>4</Length><AccessMode>RW</AccessMode>
    <pPort>Device</pPort><Cachable>NoCache</Cachable><Endianess>LittleEndian</Endianess></FloatReg>

  <!-- Digital I/O control -->

  <Category Name="DigitalIOControl" NameSpace="Standard">
    <pFeature>LineSelector</pFeature>
    <pFeature>LineMode</pFeature>
    <pFeature>LineSource</pFeature>
    <pFeature>UserOutputSelector</pFeature>
    <pFeature>UserOutputValue</pFeature>
  </Category>

  <Enumeration Name="LineSelector" NameSpace="Standard">
    <ToolTip>I/O line that the line features configure.</ToolTip>
    <EnumEntry Name="Line0" NameSpace="Standard"><Value>0</Value></EnumEntry>
    <EnumEntry Name="Line1" NameSpace="Standard"><Value>1</Value></EnumEntry>
    <EnumEntry Name="Line2" NameSpace="Standard"><Value>2</Value></EnumEntry>
    <pValue>LineSelectorReg</pValue>
    <pSelected>LineMode</pSelected>
    <pSelected>LineSource</pSelected>
  </Enumeration>
  <IntReg Name="LineSelectorReg"><Address>0x100060</Address><Length>4</Length><AccessMode>RW</AccessMode>
    <pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>LittleEndian</Endianess></IntReg>

  <Enumeration Name="LineMode" NameSpace="Standard">
    <ToolTip>Direction of the selected line.</ToolTip>
    <EnumEntry Name="Input" NameSpace="Standard"><Value>0</Value></EnumEntry>
    <EnumEntry Name="Output" NameSpace="Standard"><Value>1</Value></EnumEntry>
    <pValue>LineModeReg</pValue>
  </Enumeration>
  <IntReg Name="LineModeReg"><Address>0x100064</Address><Length>4</Length><AccessMode>RW</AccessMode>
    <pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>LittleEndian</Endianess></IntReg>

  <Enumeration Name="LineSource" NameSpace="Standard">
    <ToolTip>Signal driving the selected output line.</ToolTip>
    <EnumEntry Name="Off" NameSpace="Standard"><Value>0</Value></EnumEntry>
    <EnumEntry Name="UserOutput0" NameSpace="Standard"><Value>1</Value></EnumEntry>
    <pValue>LineSourceReg</pValue>
  </Enumeration>
  <IntReg Name="LineSourceReg"><Address>0x100068</Address><Length>4</Length><AccessMode>RW</AccessMode>
    <pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>LittleEndian</Endianess></IntReg>

  <Enumeration Name="UserOutputSelector" NameSpace="Standard">
    <ToolTip>User output that UserOutputValue sets.</ToolTip>
    <EnumEntry Name="UserOutput0" NameSpace="Standard"><Value>0</Value></EnumEntry>
    <pValue>UserOutputSelectorReg</pValue>
    <pSelected>UserOutputValue</pSelected>
  </Enumeration>
  <IntReg Name="UserOutputSelectorReg"><Address>0x10006C</Address><Length>4</Length><AccessMode>RW</AccessMode>
    <pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>LittleEndian</Endianess></IntReg>

  <Boolean Name="UserOutputValue" NameSpace="Standard"><ToolTip>Level of the selected user output.</ToolTip>
    <pValue>UserOutputValueReg</pValue><OnValue>1</OnValue><OffValue>0</OffValue></Boolean>
  <IntReg Name="UserOutputValueReg"><Address>0x100070</Address><Length>4</Length><AccessMode>RW</AccessMode>
    <pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>LittleEndian</Endianess></IntReg>

  <!-- Transport layer control -->

  <Category Name="TransportLayerControl" NameSpace="Standard">
    <pFeature>PayloadSize</pFeature>
    <pFeature>TLParamsLocked</pFeature>
  </Category>

  <Integer Name="PayloadSize" NameSpace="Standard"><ToolTip>Size of one frame's payload, in bytes.</ToolTip>
    <pValue>PayloadSizeReg</pValue><Unit>B</Unit></Integer>
  <IntReg Name="PayloadSizeReg"><Address>0x10002C</Address><Length>4</Length><AccessMode>RO</AccessMode>
    <pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>LittleEndian</Endianess></IntReg>

  <Integer Name="TLParamsLocked" NameSpace="Standard"><ToolTip>Set by the host while it streams.</ToolTip>
    <Visibility>Invisible</Visibility><Value>0</Value><Min>0</Min><Max>1</Max></Integer>

  <Port Name="Device" NameSpace="Standard"><ToolTip>The device's GenCP register space.</ToolTip></Port>

</RegisterDescription>
)xml";

}  // namespace lfi::emulation::u3v
