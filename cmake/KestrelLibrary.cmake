# Kestrel's libraries and processes, declared once each (in the manner of PX4's px4_add_library).
#
# kestrel_warnings(<target>)
#   Warnings on, for Kestrel's own code only; -Werror when KESTREL_WERROR is ON (CI turns it on).
#
# kestrel_add_library(NAME <kestrel_x> [STATIC] [NO_WARNINGS] [NO_INSTALL]
#                     SOURCES <file>...  [PUBLIC_DEPS <dep>...]  [PRIVATE_DEPS <dep>...]
#                     [HEADERS <file>...]  [COMPONENT <component>])
#   Adds the library <kestrel_x> (static unless BUILD_SHARED_LIBS) and the alias kestrel::<x>
#   (the name without "kestrel_"), with Kestrel's warnings, the repository root as its public
#   include root (headers are included as "mapping/grid.h"), and links PUBLIC_DEPS / PRIVATE_DEPS.
#   Unless NO_INSTALL it is installed and exported as kestrel::<x> (KestrelTargets, read by
#   KestrelConfig.cmake), and the public headers of its folder (every *.h there, plus HEADERS)
#   go to <includedir>/kestrel/<folder>/, once per folder. COMPONENT (default
#   ${KESTREL_DEV_COMPONENT}) is the CPack component of the library and its headers.
#
# kestrel_areas_built(<out_var> <area>...)
#   Sets <out_var> ON if every named area is in KESTREL_AREAS (the areas of this build), else OFF.
#
# kestrel_add_process(NAME <kestrel-x> SOURCES <file>... [DEPS <dep>...] [COMPONENT <component>]
#                     [NO_INSTALL])
#   Adds the executable <kestrel-x> with Kestrel's warnings, linked privately to DEPS, installed
#   into <bindir> as part of COMPONENT (host or vehicle: the two Debian packages). Each process is
#   also linked into <build>/bin, the build tree's one folder of binaries (the sheets' $KESTREL_BIN).
include_guard(GLOBAL)
include(GNUInstallDirs)

set(KESTREL_INSTALL_INCLUDEDIR ${CMAKE_INSTALL_INCLUDEDIR}/kestrel)
set(KESTREL_INSTALL_DATADIR ${CMAKE_INSTALL_DATADIR}/kestrel)
set(KESTREL_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/Kestrel)
# Libraries, headers and the CMake package go with the host's package (development is on the host).
set(KESTREL_DEV_COMPONENT host)
set(CMAKE_INSTALL_DEFAULT_COMPONENT_NAME host)

function(kestrel_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow=local
                                           -Wnon-virtual-dtor -Wold-style-cast)
  if(KESTREL_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()

# Installs the *.h of <dir> (a folder of the source tree) once, whichever library asks first.
function(kestrel_install_headers dir component)
  get_property(done GLOBAL PROPERTY KESTREL_HEADER_DIRS)
  if(dir IN_LIST done)
    return()
  endif()
  set_property(GLOBAL APPEND PROPERTY KESTREL_HEADER_DIRS ${dir})
  file(GLOB headers ${dir}/*.h)
  file(RELATIVE_PATH rel ${PROJECT_SOURCE_DIR} ${dir})
  if(headers)
    install(FILES ${headers} DESTINATION ${KESTREL_INSTALL_INCLUDEDIR}/${rel}
            COMPONENT ${component})
  endif()
endfunction()

function(kestrel_add_library)
  cmake_parse_arguments(L "STATIC;NO_WARNINGS;NO_INSTALL" "NAME;COMPONENT"
                        "SOURCES;PUBLIC_DEPS;PRIVATE_DEPS;HEADERS" ${ARGN})
  if(NOT L_NAME OR NOT L_SOURCES)
    message(FATAL_ERROR "kestrel_add_library: NAME and SOURCES are required")
  endif()
  if(L_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "kestrel_add_library(${L_NAME}): unknown arguments ${L_UNPARSED_ARGUMENTS}")
  endif()
  if(NOT L_COMPONENT)
    set(L_COMPONENT ${KESTREL_DEV_COMPONENT})
  endif()
  set(type)
  if(L_STATIC)
    set(type STATIC)
  endif()
  add_library(${L_NAME} ${type} ${L_SOURCES})
  string(REGEX REPLACE "^kestrel_" "" short ${L_NAME})
  add_library(kestrel::${short} ALIAS ${L_NAME})
  set_target_properties(${L_NAME} PROPERTIES EXPORT_NAME ${short})
  target_include_directories(${L_NAME} PUBLIC $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}>
                                              $<INSTALL_INTERFACE:${KESTREL_INSTALL_INCLUDEDIR}>)
  target_link_libraries(${L_NAME} PUBLIC ${L_PUBLIC_DEPS} PRIVATE ${L_PRIVATE_DEPS})
  if(NOT L_NO_WARNINGS)
    kestrel_warnings(${L_NAME})
  endif()
  if(NOT L_NO_INSTALL)
    set_property(GLOBAL APPEND PROPERTY KESTREL_EXPORTED_LIBRARIES kestrel::${short})
    install(TARGETS ${L_NAME} EXPORT KestrelTargets
            ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT ${L_COMPONENT}
            LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT ${L_COMPONENT}
            INCLUDES DESTINATION ${KESTREL_INSTALL_INCLUDEDIR})
    kestrel_install_headers(${CMAKE_CURRENT_SOURCE_DIR} ${L_COMPONENT})
    foreach(h ${L_HEADERS})
      get_filename_component(abs ${h} ABSOLUTE)
      get_filename_component(dir ${abs} DIRECTORY)
      file(RELATIVE_PATH rel ${PROJECT_SOURCE_DIR} ${dir})
      install(FILES ${abs} DESTINATION ${KESTREL_INSTALL_INCLUDEDIR}/${rel}
              COMPONENT ${L_COMPONENT})
    endforeach()
  endif()
endfunction()

function(kestrel_add_process)
  cmake_parse_arguments(P "NO_INSTALL" "NAME;COMPONENT" "SOURCES;DEPS" ${ARGN})
  if(NOT P_NAME OR NOT P_SOURCES)
    message(FATAL_ERROR "kestrel_add_process: NAME and SOURCES are required")
  endif()
  if(P_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "kestrel_add_process(${P_NAME}): unknown arguments ${P_UNPARSED_ARGUMENTS}")
  endif()
  if(NOT P_NO_INSTALL AND NOT P_COMPONENT)
    message(FATAL_ERROR "kestrel_add_process(${P_NAME}): COMPONENT host|vehicle is required")
  endif()
  add_executable(${P_NAME} ${P_SOURCES})
  target_link_libraries(${P_NAME} PRIVATE ${P_DEPS})
  kestrel_warnings(${P_NAME})
  # Every process also in <build>/bin (a link), the one folder the sheets' $KESTREL_BIN names.
  add_custom_command(TARGET ${P_NAME} POST_BUILD
                     COMMAND ${CMAKE_COMMAND} -E make_directory ${PROJECT_BINARY_DIR}/bin
                     COMMAND ${CMAKE_COMMAND} -E create_symlink $<TARGET_FILE:${P_NAME}>
                             ${PROJECT_BINARY_DIR}/bin/${P_NAME}
                     VERBATIM)
  if(NOT P_NO_INSTALL)
    install(TARGETS ${P_NAME} RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT ${P_COMPONENT})
  endif()
endfunction()

function(kestrel_areas_built out_var)
  set(built ON)
  foreach(area ${ARGN})
    if(NOT area IN_LIST KESTREL_AREAS)
      set(built OFF)
    endif()
  endforeach()
  set(${out_var} ${built} PARENT_SCOPE)
endfunction()
