// SPDX-License-Identifier: Apache-2.0
// Linked into every test and the `lfi` program of the ThreadSanitizer build
// (LFI_SANITIZE_THREAD, tests/CMakeLists.txt):
// TBB's scheduler is not instrumented, so the hand-over of work between its
// threads is invisible to ThreadSanitizer and every task's access would be
// reported. With TBB held to one thread what still runs on it (Embree's BVH
// builds, OpenCV's parallel loops where OpenCV uses TBB) runs on the thread
// that calls it. lfi's own parallel loops run on std::threads in this build
// (sim/src/parallel_for.h), so ThreadSanitizer checks them, with lfi's other
// threads: the sim: camera's stream, the Aravis and USB backends', the
// emulated devices'.
#include <oneapi/tbb/global_control.h>

namespace {
const tbb::global_control serial(tbb::global_control::max_allowed_parallelism, 1);
}  // namespace
