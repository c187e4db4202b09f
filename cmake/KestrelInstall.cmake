# What `cmake --install` puts under the prefix (GNUInstallDirs layout), besides the libraries,
# headers and processes that kestrel_add_library / kestrel_add_process install:
#   <libdir>/cmake/Kestrel/   KestrelConfig.cmake, KestrelConfigVersion.cmake, KestrelTargets*.cmake
#   <datadir>/kestrel/        config/ and sheets/ (run the sheets from here, see README), web/
#   <datadir>/doc/kestrel/    LICENSE
# Everything belongs to one of two CPack components, the two Debian packages (KestrelPackaging):
# vehicle (drivers, controller, vicon bridge, runner, their configuration) and host (the rest).
include(CMakePackageConfigHelpers)

# The CMake package.
get_property(KESTREL_EXPORTED_LIBRARIES GLOBAL PROPERTY KESTREL_EXPORTED_LIBRARIES)
list(JOIN KESTREL_EXPORTED_LIBRARIES ", " KESTREL_EXPORTED_LIBRARIES)
if(TARGET kestrel_usb)
  set(KESTREL_EXPORTS_LIBUSB TRUE)
else()
  set(KESTREL_EXPORTS_LIBUSB FALSE)
endif()
install(EXPORT KestrelTargets NAMESPACE kestrel:: DESTINATION ${KESTREL_INSTALL_CMAKEDIR}
        COMPONENT ${KESTREL_DEV_COMPONENT})
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/KestrelConfig.cmake.in
                              ${PROJECT_BINARY_DIR}/KestrelConfig.cmake
                              INSTALL_DESTINATION ${KESTREL_INSTALL_CMAKEDIR}
                              PATH_VARS KESTREL_INSTALL_DATADIR)
write_basic_package_version_file(${PROJECT_BINARY_DIR}/KestrelConfigVersion.cmake
                                 VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/KestrelConfig.cmake ${PROJECT_BINARY_DIR}/KestrelConfigVersion.cmake
        DESTINATION ${KESTREL_INSTALL_CMAKEDIR} COMPONENT ${KESTREL_DEV_COMPONENT})
