// SPDX-License-Identifier: Apache-2.0
#pragma once
// Internal to lfi_sim: the attribute that builds a loop-heavy function for
// several instruction sets, chosen at load time. The functions it marks run
// the same arithmetic on every lane with selects instead of branches, so that
// the compiler vectorises their loops; their source files are compiled with
// -fno-math-errno -fno-trapping-math (sim/CMakeLists.txt), and the project
// with -ffp-contract=off: without fused multiply-adds every clone gives the
// same bits. Off under
// AddressSanitizer and ThreadSanitizer, whose run times are not up yet when the
// loader runs the clones' resolvers. Off too when the build itself targets AVX2 or better
// (-march=native, -march=x86-64-v3): a clone's target("arch=x86-64-v4") then
// lacks some of the build's own features, so GCC 12 will not inline the small
// helpers (RayMap::trace, concentricDisc, the Fresnel lane) into it, and the
// render ran 1.65x slower than a plain build (measured; plain: same speed).

// (Not with clang, the fuzz build's compiler: it takes no target_clones on templates.)
#if defined(__x86_64__) && !defined(__SANITIZE_ADDRESS__) && !defined(__SANITIZE_THREAD__) && !defined(__AVX2__) && \
    !defined(__clang__)
#define LFI_SIMD_CLONES __attribute__((target_clones("arch=x86-64-v4", "avx2", "default")))
#else
#define LFI_SIMD_CLONES
#endif
