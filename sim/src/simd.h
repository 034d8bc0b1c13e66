#pragma once
// Internal to lfi_sim: the attribute that builds a loop-heavy function for
// several instruction sets, chosen at load time. The functions it marks run
// the same arithmetic on every lane with selects instead of branches, so that
// the compiler vectorises their loops; their source files are compiled with
// -fno-math-errno -fno-trapping-math -ffp-contract=off (sim/CMakeLists.txt):
// without fused multiply-adds every clone gives the same bits. Off under
// AddressSanitizer, whose run time is not up yet when the loader runs the
// clones' resolvers.

#if defined(__x86_64__) && !defined(__SANITIZE_ADDRESS__)
#define LFI_SIMD_CLONES __attribute__((target_clones("arch=x86-64-v4", "avx2", "default")))
#else
#define LFI_SIMD_CLONES
#endif
