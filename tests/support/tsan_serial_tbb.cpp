// Linked into every test of the ThreadSanitizer build (LFI_SANITIZE_THREAD):
// TBB's scheduler is not instrumented, so the hand-over of work between its
// threads is invisible to ThreadSanitizer and every parallel_for body would be
// reported. With TBB held to one thread the parallel loops (and Embree's BVH
// builds on TBB) run on the thread that calls them, and what ThreadSanitizer
// checks is lfi's own threads: the sim: camera's stream, the Aravis and USB
// backends', the emulated devices'.
#include <oneapi/tbb/global_control.h>

namespace {
const tbb::global_control serial(tbb::global_control::max_allowed_parallelism, 1);
}  // namespace
