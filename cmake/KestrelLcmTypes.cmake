# kestrel_lcm_types(TARGET <name> PACKAGE <pkg> FILES <a.lcm>...)
# FILES must list every .lcm file of the calling folder.
# Runs lcm-gen in the build tree (never the source tree) for C++ headers and Java sources, compiles
# the Java into a jar for lcm-spy, and makes an INTERFACE library <name> carrying the include path.
# Also generates the Python types (<build>/lcmtypes/python/<pkg>/, pure Python: struct only),
# installed into KESTREL_INSTALL_PYTHONDIR (Debian's dist-packages under the prefix).
# Editing any .lcm file regenerates on the next build (add_custom_command DEPENDS).
find_program(LCM_GEN_EXECUTABLE lcm-gen REQUIRED)
find_package(Java COMPONENTS Development)
find_file(LCM_JAR lcm.jar PATHS /usr/share/java NO_DEFAULT_PATH)
set(KESTREL_INSTALL_PYTHONDIR lib/python3/dist-packages CACHE STRING
    "Where the Python message types are installed, relative to the prefix")

function(kestrel_lcm_types)
  cmake_parse_arguments(L "" "TARGET;PACKAGE" "FILES" ${ARGN})
  # Every .lcm file of the folder must be listed (a forgotten file is an error, as in Drake's
  # lcmtypes build).
  file(GLOB present RELATIVE ${CMAKE_CURRENT_SOURCE_DIR} CONFIGURE_DEPENDS
       ${CMAKE_CURRENT_SOURCE_DIR}/*.lcm)
  foreach(f ${present})
    if(NOT f IN_LIST L_FILES)
      file(RELATIVE_PATH folder ${PROJECT_SOURCE_DIR} ${CMAKE_CURRENT_SOURCE_DIR})
      message(FATAL_ERROR "${folder}/${f} is not listed in ${folder}/CMakeLists.txt")
    endif()
  endforeach()
  set(cpp_dir ${CMAKE_CURRENT_BINARY_DIR}/cpp)
  set(java_dir ${CMAKE_CURRENT_BINARY_DIR}/java)
  set(headers)
  set(java_sources)
  foreach(lcm_file ${L_FILES})
    get_filename_component(abs ${lcm_file} ABSOLUTE)
    get_filename_component(stem ${lcm_file} NAME_WE)
    # lcm-gen names the generated type after the struct; our files are named <pkg>_<struct>.lcm.
    string(REGEX REPLACE "^${L_PACKAGE}_" "" struct ${stem})
    set(hdr ${cpp_dir}/${L_PACKAGE}/${struct}.hpp)
    set(java ${java_dir}/${L_PACKAGE}/${struct}.java)
    add_custom_command(
      OUTPUT ${hdr} ${java}
      COMMAND ${LCM_GEN_EXECUTABLE} --cpp --cpp-hpath ${cpp_dir} ${abs}
      # lcm-gen 1.3.1 emits `static const int8_t K = 1;`, which C++17 does not make inline: any
      # ODR-use (a reference, EXPECT_EQ, std::max) fails to link. constexpr members are inline.
      COMMAND sed -i -E "s/^([ ]*)static const ([a-z0-9_]+[ ]+[A-Za-z0-9_]+[ ]*=)/\\1static constexpr \\2/" ${hdr}
      COMMAND ${LCM_GEN_EXECUTABLE} --java --jpath ${java_dir} ${abs}
      DEPENDS ${abs}
      COMMENT "lcm-gen ${stem}.lcm"
      VERBATIM)
    list(APPEND headers ${hdr})
    list(APPEND java_sources ${java})
  endforeach()
  add_custom_target(${L_TARGET}_cpp DEPENDS ${headers})

  # Python: one lcm-gen run over every file, into a fresh folder (lcm-gen adds to an existing
  # __init__.py, so a removed type would linger). The generated modules import each other as
  # <pkg>.<struct>, so the package keeps the LCM package's name.
  set(py_dir ${CMAKE_CURRENT_BINARY_DIR}/python)
  set(py_files ${py_dir}/${L_PACKAGE}/__init__.py)
  set(lcm_abs)
  foreach(lcm_file ${L_FILES})
    get_filename_component(abs ${lcm_file} ABSOLUTE)
    get_filename_component(stem ${lcm_file} NAME_WE)
    string(REGEX REPLACE "^${L_PACKAGE}_" "" struct ${stem})
    list(APPEND lcm_abs ${abs})
    list(APPEND py_files ${py_dir}/${L_PACKAGE}/${struct}.py)
  endforeach()
  add_custom_command(
    OUTPUT ${py_files}
    COMMAND ${CMAKE_COMMAND} -E remove_directory ${py_dir}/${L_PACKAGE}
    COMMAND ${LCM_GEN_EXECUTABLE} --python --ppath ${py_dir} ${lcm_abs}
    DEPENDS ${lcm_abs}
    COMMENT "lcm-gen --python (${L_PACKAGE})"
    VERBATIM)
  add_custom_target(${L_TARGET}_python ALL DEPENDS ${py_files})
  set(${L_TARGET}_PYTHON_DIR ${py_dir} PARENT_SCOPE)
  install(FILES ${py_files} DESTINATION ${KESTREL_INSTALL_PYTHONDIR}/${L_PACKAGE}
          COMPONENT ${KESTREL_DEV_COMPONENT})
  add_library(${L_TARGET} INTERFACE)
  target_include_directories(${L_TARGET} SYSTEM INTERFACE
                             $<BUILD_INTERFACE:${cpp_dir}>
                             $<INSTALL_INTERFACE:${KESTREL_INSTALL_INCLUDEDIR}>)
  target_link_libraries(${L_TARGET} INTERFACE PkgConfig::LCM)
  add_dependencies(${L_TARGET} ${L_TARGET}_cpp)
  # Installed and exported like every library (kestrel::<name without kestrel_>); the headers go
  # to <includedir>/kestrel/<package>/, included as "<package>/<struct>.hpp".
  string(REGEX REPLACE "^kestrel_" "" short ${L_TARGET})
  add_library(kestrel::${short} ALIAS ${L_TARGET})
  set_target_properties(${L_TARGET} PROPERTIES EXPORT_NAME ${short})
  set_property(GLOBAL APPEND PROPERTY KESTREL_EXPORTED_LIBRARIES kestrel::${short})
  install(TARGETS ${L_TARGET} EXPORT KestrelTargets)
  install(FILES ${headers} DESTINATION ${KESTREL_INSTALL_INCLUDEDIR}/${L_PACKAGE}
          COMPONENT ${KESTREL_DEV_COMPONENT})

  if(Java_JAVAC_EXECUTABLE AND Java_JAR_EXECUTABLE AND LCM_JAR)
    set(jar ${CMAKE_CURRENT_BINARY_DIR}/${L_TARGET}.jar)
    set(classes ${CMAKE_CURRENT_BINARY_DIR}/classes)
    add_custom_command(
      OUTPUT ${jar}
      COMMAND ${CMAKE_COMMAND} -E remove_directory ${classes}
      COMMAND ${CMAKE_COMMAND} -E make_directory ${classes}
      COMMAND ${Java_JAVAC_EXECUTABLE} -nowarn -source 8 -target 8 -cp ${LCM_JAR} -d ${classes} ${java_sources}
      COMMAND ${Java_JAR_EXECUTABLE} cf ${jar} -C ${classes} .
      DEPENDS ${java_sources}
      COMMENT "javac + jar ${L_TARGET}.jar (for lcm-spy)"
      VERBATIM)
    add_custom_target(${L_TARGET}_jar ALL DEPENDS ${jar})
    set(${L_TARGET}_JAR ${jar} PARENT_SCOPE)
    # Installed beside Debian's lcm.jar: lcm-spy -cp /usr/share/java/lcm.jar:.../<name>.jar
    install(FILES ${jar} DESTINATION ${CMAKE_INSTALL_DATADIR}/java COMPONENT ${KESTREL_DEV_COMPONENT})
  else()
    message(WARNING "javac, jar or lcm.jar missing: the lcm-spy types jar is not built")
  endif()
endfunction()
