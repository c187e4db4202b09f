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

# Configuration: what the vehicle's processes read goes with the vehicle, the rest with the host.
set(config_dir ${PROJECT_SOURCE_DIR}/config)
install(DIRECTORY ${config_dir}/drivers ${config_dir}/vehicle
        DESTINATION ${KESTREL_INSTALL_DATADIR}/config COMPONENT vehicle)
install(DIRECTORY ${config_dir}/exploration ${config_dir}/sim ${config_dir}/worlds
        DESTINATION ${KESTREL_INSTALL_DATADIR}/config COMPONENT host)
install(FILES ${config_dir}/mapper.yaml ${config_dir}/viewer.yaml
        DESTINATION ${KESTREL_INSTALL_DATADIR}/config COMPONENT host)

# Process sheets. The installed copies are run from <datadir>/kestrel (their configuration paths
# are relative to the working folder, as from the repository root) and are the build tree's,
# unchanged; their variables' defaults (sheets/kestrel.env) name <bindir> relative to that folder
# (../../bin) as $KESTREL_BIN instead of the build tree's build/bin.
file(RELATIVE_PATH sheet_bindir ${CMAKE_INSTALL_FULL_DATADIR}/kestrel ${CMAKE_INSTALL_FULL_BINDIR})
set(env_source ${PROJECT_SOURCE_DIR}/scripts/sheets/kestrel.env)
set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${env_source})
file(READ ${env_source} text)
string(REGEX REPLACE "\nKESTREL_BIN=[^\n]*" "\nKESTREL_BIN=${sheet_bindir}" text "${text}")
string(PREPEND text "# Installed copy of scripts/sheets/kestrel.env: run the sheets from "
                    "<prefix>/${KESTREL_INSTALL_DATADIR}.\n")
file(CONFIGURE OUTPUT ${PROJECT_BINARY_DIR}/sheets/kestrel.env CONTENT "${text}" @ONLY)
# kestrel-procman, which reads it, is in the vehicle package; the host's depends on it.
install(FILES ${PROJECT_BINARY_DIR}/sheets/kestrel.env
        DESTINATION ${KESTREL_INSTALL_DATADIR}/sheets COMPONENT vehicle)
# two_vehicles.procman holds both vehicles' commands and the host's: the vehicles need it, and the
# host package depends on the vehicle package.
install(FILES ${PROJECT_SOURCE_DIR}/scripts/sheets/vehicle.procman
              ${PROJECT_SOURCE_DIR}/scripts/sheets/two_vehicles.procman
        DESTINATION ${KESTREL_INSTALL_DATADIR}/sheets COMPONENT vehicle)
install(FILES ${PROJECT_SOURCE_DIR}/scripts/sheets/host.procman
              ${PROJECT_SOURCE_DIR}/scripts/sheets/sim.procman
              ${PROJECT_SOURCE_DIR}/scripts/sheets/chaos_sim.procman
              ${PROJECT_SOURCE_DIR}/scripts/sheets/hil_sim.procman
              ${PROJECT_SOURCE_DIR}/scripts/sheets/two_vehicles_sim.procman
        DESTINATION ${KESTREL_INSTALL_DATADIR}/sheets COMPONENT host)

# The licence, as Debian's /usr/share/doc/<package>/copyright of each package.
foreach(component vehicle host)
  install(FILES ${PROJECT_SOURCE_DIR}/LICENSE DESTINATION ${CMAKE_INSTALL_DATADIR}/doc/kestrel-${component}
          RENAME copyright COMPONENT ${component})
endforeach()
