# `cmake --install`: the four library layers as a CMake package (pbdam::formats, pbdam::runtime,
# pbdam::streaming, pbdam::gpu; lib/cmake/pbdam) and a pkg-config file (lib/pkgconfig/pbdam.pc),
# their public headers (include/pbdam/<layer>/) and the image codec module they load at run time.
# The builder and the command line are not installed: they are the pbdam tool's, not an API
# (docs/embedding.md "What is public").
include(CMakePackageConfigHelpers)

set(PBDAM_INSTALLED_LAYERS formats runtime streaming gpu)
# Until 1.0 every minor version may change the ABI: the shared libraries' SONAME and the package's
# compatibility are major.minor (libpbdam_gpu.so.0.1; find_package(pbdam 0.1) accepts 0.1.x only).
set(PBDAM_SOVERSION ${PROJECT_VERSION_MAJOR}.${PROJECT_VERSION_MINOR})
set(installedTargets)
foreach(layer IN LISTS PBDAM_INSTALLED_LAYERS)
  set(target pbdam_${layer})
  # pbdam::<layer> in this tree too, so that code written against the package builds in it.
  add_library(pbdam::${layer} ALIAS ${target})
  # Shared, each finds the layers below it and the image codec module beside itself ($ORIGIN).
  set_target_properties(${target} PROPERTIES EXPORT_NAME ${layer} VERSION ${PROJECT_VERSION}
                                             SOVERSION ${PBDAM_SOVERSION} INSTALL_RPATH $ORIGIN)
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/${layer}/include/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
          FILES_MATCHING PATTERN "*.h")
  list(APPEND installedTargets ${target})
endforeach()
install(TARGETS ${installedTargets} EXPORT pbdamTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
        RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
# The image codec (formats/ImageCodec.h) is dlopen'd by name from the lib directory (Module.h).
install(TARGETS pbdam_oiio LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})

set(packageDir ${CMAKE_INSTALL_LIBDIR}/cmake/pbdam)
install(EXPORT pbdamTargets NAMESPACE pbdam:: DESTINATION ${packageDir})
# A static pbdam_formats, pbdam_runtime, ... carries its private dependencies into every
# executable that links it: the package finds them too (pbdamConfig.cmake.in).
get_target_property(formatsType pbdam_formats TYPE)
if(formatsType STREQUAL "STATIC_LIBRARY")
  set(PBDAM_STATIC_LIBRARIES ON)
else()
  set(PBDAM_STATIC_LIBRARIES OFF)
endif()
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/pbdamConfig.cmake.in
                              ${PROJECT_BINARY_DIR}/pbdamConfig.cmake
                              INSTALL_DESTINATION ${packageDir}
                              PATH_VARS CMAKE_INSTALL_LIBDIR)
write_basic_package_version_file(${PROJECT_BINARY_DIR}/pbdamConfigVersion.cmake
                                 COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/pbdamConfig.cmake ${PROJECT_BINARY_DIR}/pbdamConfigVersion.cmake
        DESTINATION ${packageDir})

# pbdam.pc, relocatable: its prefix is found from where the file is (${pcfiledir}), so that
# `cmake --install --prefix P` anywhere gives a working file. Static libraries need their
# dependencies on every link line, so they are Requires and Libs, not the .private fields.
file(RELATIVE_PATH PBDAM_PC_PREFIX_FROM_PCDIR
     /prefix/${CMAKE_INSTALL_LIBDIR}/pkgconfig /prefix)
string(REGEX REPLACE "/$" "" PBDAM_PC_PREFIX_FROM_PCDIR "${PBDAM_PC_PREFIX_FROM_PCDIR}")
set(PBDAM_PC_REQUIRES "vulkan glm")
# The RUNPATH is where a program finds the shared libraries, or (static) the image codec module
# (Module.h), whatever the prefix.
set(PBDAM_PC_LIBS
    "-lpbdam_gpu -lpbdam_streaming -lpbdam_runtime -lpbdam_formats -pthread -Wl,-rpath,\${libdir}")
set(privateRequires "tbb gdal zlib lzo2 geographiclib")
set(privateLibs "-lmeshoptimizer -lsquish -ldl")
if(PBDAM_STATIC_LIBRARIES)
  string(APPEND PBDAM_PC_REQUIRES " ${privateRequires}")
  string(APPEND PBDAM_PC_LIBS " ${privateLibs}")
  set(PBDAM_PC_PRIVATE "")
else()
  set(PBDAM_PC_PRIVATE "Requires.private: ${privateRequires}\nLibs.private: ${privateLibs}\n")
endif()
configure_file(${CMAKE_CURRENT_LIST_DIR}/pbdam.pc.in ${PROJECT_BINARY_DIR}/pbdam.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/pbdam.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)
