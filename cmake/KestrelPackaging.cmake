# Debian packages (cpack -G DEB in the build folder), one per install component:
#   kestrel-vehicle  what runs on the vehicle: kestrel-procman (the runner), kestrel-controller,
#                    the drivers (xtion + its OpenNI2 plugin, hokuyo + emulator, vicon bridge +
#                    emitter, devices), config/drivers, config/vehicle, the vehicle sheet
#   kestrel-host     the rest: mapper, explorer, simulator, viewer (+ page), kestrel-report, the
#                    tools, the host and sim sheets and their configuration, and the development
#                    files (static libraries, headers, CMake package, Python types, lcm-spy jar);
#                    depends on kestrel-vehicle (the sim sheet runs the controller and the runner)
# Shared-library dependencies come from dpkg-shlibdeps; programs the sheets and scripts run are
# listed explicitly. The processes are linked statically against Kestrel's own libraries.
set(CPACK_PACKAGE_NAME kestrel)
set(CPACK_PACKAGE_VENDOR "The Kestrel authors")
set(CPACK_PACKAGE_CONTACT "The Kestrel authors")
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY
    "Autonomous quadrotor 3D mapping and exploration with exact occupancy probabilities")
set(CPACK_RESOURCE_FILE_LICENSE ${PROJECT_SOURCE_DIR}/LICENSE)
set(CPACK_PACKAGE_DIRECTORY ${PROJECT_BINARY_DIR}/packages)
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)

set(CPACK_COMPONENTS_ALL vehicle host)
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_COMPONENT_VEHICLE_DISPLAY_NAME "Kestrel on the vehicle")
string(CONCAT CPACK_COMPONENT_VEHICLE_DESCRIPTION
    "Kestrel on the vehicle (the Jetson): the process-sheet runner kestrel-procman, the flight\n"
    "controller, the Xtion, Hokuyo and Vicon drivers, their configuration and the vehicle sheet\n"
    "(/usr/share/kestrel).")
set(CPACK_COMPONENT_HOST_DISPLAY_NAME "Kestrel on the host")
string(CONCAT CPACK_COMPONENT_HOST_DESCRIPTION
    "Kestrel on the host: mapper, explorer, simulator, live viewer, report, the tools\n"
    "(kestrel-cmd, kestrel-flight-check, kestrel-map-score, kestrel-mission, kestrel-fidelity,\n"
    "kestrel-calibrate), the host and\n"
    "simulation sheets with their configuration (/usr/share/kestrel), and the development files:\n"
    "static libraries, headers, the CMake package (find_package(Kestrel), kestrel:: targets),\n"
    "the Python message types and the lcm-spy types jar.")
set(CPACK_COMPONENT_HOST_DEPENDS vehicle)  # Depends: kestrel-vehicle (= version)
set(CPACK_DEBIAN_ENABLE_COMPONENT_DEPENDS ON)
set(CPACK_DEBIAN_VEHICLE_PACKAGE_NAME kestrel-vehicle)
set(CPACK_DEBIAN_HOST_PACKAGE_NAME kestrel-host)
# lcm-logger (host and sim sheets), lcm-logplayer (replay); python3 for kestrel-report and the
# Python types; matplotlib draws the report's figures.
set(CPACK_DEBIAN_HOST_PACKAGE_DEPENDS "liblcm-bin, python3")
set(CPACK_DEBIAN_HOST_PACKAGE_RECOMMENDS
    "python3-matplotlib, liblcm-java, libjchart2d-java, default-jre-headless")
# What find_package(Kestrel) and the exported kestrel:: targets need to compile and link.
set(CPACK_DEBIAN_HOST_PACKAGE_SUGGESTS
    "liblcm-dev, libeigen3-dev, libyaml-cpp-dev, zlib1g-dev, libbullet-dev, liboctomap-dev, libhwy-dev, libusb-1.0-0-dev, libopenni2-dev, pkg-config")
include(CPack)
