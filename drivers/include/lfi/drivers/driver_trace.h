// SPDX-License-Identifier: Apache-2.0
#pragma once
// A trace of the calls lfi makes to its devices, for a user diagnosing a
// bench ("what did it send to my camera?") and for the hardware-in-the-loop
// tests, which show that a run over the real drivers made every call the bench
// path makes. Off unless the environment variable LFI_DRIVER_TRACE names a
// file; then each process appends to it, one line per call (one write each, so
// that processes sharing the file do not tear each other's lines):
//
//   column   meaning
//   time     seconds since the Unix epoch, to the microsecond
//   pid      the process
//   layer    camera | display: a call of the Camera or Display interface, on
//            any backend (openCamera and openDisplay wrap the device);
//            aravis | usb: what the real backend then did: an Aravis call and
//            its arguments, a USB request by name, a bulk transfer's bytes;
//            served: the device side of a simulated bench (`lfi sim-bench`):
//            a frame made, a panel taken
//   device   the URI the device was opened by (camera, display), the
//            backend's name for it (aravis, usb), its serial (served)
//   call     the method or request
//   detail   arguments and results
//
// Columns are separated by tabs; a file this creates starts with a '#' line
// that names them. A file that cannot be opened turns the trace off with one
// warning.

#include "lfi/drivers/camera.h"
#include "lfi/drivers/display.h"

#include <memory>
#include <string>
#include <string_view>

namespace lfi {

bool driverTraceOn();
void traceDriverCall(std::string_view layer, std::string_view device, std::string_view call,
                     std::string_view detail = {});

// `device` itself when the trace is off; else a device that traces each call
// of the interface (not the reads: state, info, settings, statistics, feature
// gets) and forwards it. `uri` names it in the trace.
std::unique_ptr<Camera> traceCalls(std::unique_ptr<Camera> camera, std::string_view uri);
std::unique_ptr<Display> traceCalls(std::unique_ptr<Display> display, std::string_view uri);

}  // namespace lfi
