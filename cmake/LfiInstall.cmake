# SPDX-License-Identifier: Apache-2.0
# `cmake --install`: the libraries and their public headers (lfi_library), the
# lfi CMake package and pkg-config file, the `lfi` tool with its data, and the
# udev rules. Everything goes under CMAKE_INSTALL_PREFIX except the udev rules,
# which go where udev reads them: LFI_UDEV_RULES_DIR, by default the udev
# package's udevdir + /rules.d (/usr/lib/udev/rules.d without udev's .pc file).
include(CMakePackageConfigHelpers)

set(LFI_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/lfi)
install(EXPORT lfiTargets NAMESPACE lfi:: DESTINATION ${LFI_CMAKE_DIR})
configure_package_config_file(cmake/lfiConfig.cmake.in ${PROJECT_BINARY_DIR}/lfiConfig.cmake
                              INSTALL_DESTINATION ${LFI_CMAKE_DIR} PATH_VARS CMAKE_INSTALL_DOCDIR)
install(FILES LICENSE DESTINATION ${CMAKE_INSTALL_DOCDIR})
write_basic_package_version_file(${PROJECT_BINARY_DIR}/lfiConfigVersion.cmake COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/lfiConfig.cmake ${PROJECT_BINARY_DIR}/lfiConfigVersion.cmake
        DESTINATION ${LFI_CMAKE_DIR})

# The .pc file finds the prefix from where it lies (pkg-config's pcfiledir),
# so that `cmake --install --prefix` moves it too.
file(RELATIVE_PATH LFI_PC_PREFIX_FROM_PCFILEDIR /prefix/${CMAKE_INSTALL_LIBDIR}/pkgconfig /prefix)
configure_file(cmake/lfi.pc.in ${PROJECT_BINARY_DIR}/lfi.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/lfi.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)

pkg_get_variable(LFI_UDEVDIR udev udevdir)
if(LFI_UDEVDIR)
  set(LFI_UDEV_RULES_DEFAULT ${LFI_UDEVDIR}/rules.d)
else()
  set(LFI_UDEV_RULES_DEFAULT /usr/lib/udev/rules.d)
endif()
set(LFI_UDEV_RULES_DIR ${LFI_UDEV_RULES_DEFAULT} CACHE PATH
    "Where `cmake --install` puts the udev rules (absolute; not moved by --prefix)")
install(FILES udev/70-lfi.rules DESTINATION ${LFI_UDEV_RULES_DIR})
