# SPDX-License-Identifier: Apache-2.0
# Compiler flags shared by every lfi target. Linked as a build-only dependency:
# an installed lfi library does not impose them on its users.
add_library(lfi_options INTERFACE)
target_compile_options(lfi_options INTERFACE -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor
                       -Wconversion-null -Wno-unused-parameter
                       # GCC 12 false positives inside libstdc++ at -O3 (GCC bug 105651)
                       $<$<CXX_COMPILER_ID:GNU>:-Wno-restrict>
                       # clang (the fuzz build): the tracer's lane masks combine comparisons with & on purpose
                       $<$<CXX_COMPILER_ID:Clang>:-Wno-bitwise-instead-of-logical>
                       # designated initializers leave defaulted members out on purpose
                       -Wno-missing-field-initializers
                       # No contraction into fused multiply-adds (GCC's default for C++ even in ISO mode, on
                       # -march builds with FMA): the tracer's vectorised kernels and the one-ray code, the
                       # sensors and the light field lookups round alike, so a ray does not depend on which
                       # path or instruction set computed it, nor a test's expected value on the build.
                       -ffp-contract=off)
if(LFI_WERROR)
  target_compile_options(lfi_options INTERFACE -Werror)
endif()
if(LFI_SANITIZE)
  target_compile_options(lfi_options INTERFACE -fsanitize=address,undefined -fno-omit-frame-pointer
                         -fno-sanitize-recover=undefined)
  target_link_options(lfi_options INTERFACE -fsanitize=address,undefined)
endif()
if(LFI_SANITIZE_THREAD)
  target_compile_options(lfi_options INTERFACE -fsanitize=thread -fno-omit-frame-pointer)
  target_link_options(lfi_options INTERFACE -fsanitize=thread)
  # (sim/src/parallel_for.h runs the simulator's parallel loops on std::threads, which ThreadSanitizer sees.)
  target_compile_definitions(lfi_options INTERFACE LFI_SANITIZE_THREAD)
endif()
if(LFI_FUZZ)
  # Every library instrumented for libFuzzer's coverage as well (the sanitizers come with LFI_SANITIZE): one
  # build serves the tests under the sanitizers and the fuzz targets (fuzz/), which add libFuzzer's main.
  target_compile_options(lfi_options INTERFACE -fsanitize=fuzzer-no-link)
endif()

# lfi_library(<name> [NO_INSTALL] SOURCES ... PUBLIC_DEPS ... PRIVATE_DEPS ...): one folder,
# one library lfi_<name> (lfi::<name>), public headers in
# <folder>/include/lfi/<name>/. `cmake --install` installs the library, its
# headers and its target in the lfi CMake package (cmake/LfiInstall.cmake),
# unless NO_INSTALL.
function(lfi_library name)
  cmake_parse_arguments(ARG "NO_INSTALL" "" "SOURCES;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(lfi_${name} ${ARG_SOURCES})
  add_library(lfi::${name} ALIAS lfi_${name})
  set_target_properties(lfi_${name} PROPERTIES EXPORT_NAME ${name})
  target_include_directories(lfi_${name} PUBLIC $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
                                                $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  target_link_libraries(lfi_${name} PUBLIC ${ARG_PUBLIC_DEPS} PRIVATE $<BUILD_INTERFACE:lfi_options>
                        ${ARG_PRIVATE_DEPS})
  if(NOT ARG_NO_INSTALL)
    install(TARGETS lfi_${name} EXPORT lfiTargets)
    install(DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/include/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
  endif()
endfunction()
