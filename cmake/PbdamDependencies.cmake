# Every dependency comes from a Debian 12 package that scripts/setup.sh installs
# (scripts/packages.txt lists them). Nothing is downloaded at build time.

find_package(PkgConfig REQUIRED)
find_package(Threads REQUIRED)
find_package(GDAL 3.6 REQUIRED)

find_package(TBB CONFIG REQUIRED)
find_package(glm CONFIG REQUIRED)
find_package(CLI11 CONFIG REQUIRED)
find_package(nlohmann_json CONFIG REQUIRED)
find_package(meshoptimizer CONFIG REQUIRED)
find_package(ZLIB REQUIRED)
find_package(Vulkan REQUIRED COMPONENTS glslc)
pkg_check_modules(GeographicLib REQUIRED IMPORTED_TARGET geographiclib)
pkg_check_modules(LZO2 REQUIRED IMPORTED_TARGET lzo2)
# libsquish's pkg-config file has an empty prefix (Debian 12): locate it directly.
find_path(SQUISH_INCLUDE_DIR squish.h REQUIRED)
find_library(SQUISH_LIBRARY squish REQUIRED)
add_library(Squish::Squish UNKNOWN IMPORTED)
set_target_properties(Squish::Squish PROPERTIES IMPORTED_LOCATION ${SQUISH_LIBRARY}
                                                INTERFACE_INCLUDE_DIRECTORIES ${SQUISH_INCLUDE_DIR})
# OpenImageIO through pkg-config: its CMake package references opencv and tool binaries that
# libopenimageio-dev does not pull in.
pkg_check_modules(OpenImageIO REQUIRED IMPORTED_TARGET OpenImageIO)
# PLplot draws the benchmark report's plots (cairo PNG driver: plplot-driver-cairo).
pkg_check_modules(PLplot REQUIRED IMPORTED_TARGET plplot)
# pbdam fly's window (Debian: libglfw3-dev; X11)
find_package(glfw3 3.3 CONFIG REQUIRED)
# The distributed build (`mpirun -np N pbdam build`) through Debian's OpenMPI. pbdam itself does
# not link MPI: it loads the libpbdam_mpi.so module only when mpirun started it.
option(PBDAM_WITH_MPI "Build the MPI module for distributed builds (OpenMPI)" ON)
if(PBDAM_WITH_MPI)
  find_package(MPI REQUIRED COMPONENTS C)
  find_program(PBDAM_MPIRUN NAMES mpirun REQUIRED)
endif()
if(PBDAM_BUILD_TESTS)
  find_package(GTest CONFIG REQUIRED)
endif()
if(PBDAM_BUILD_BENCH)
  find_package(benchmark CONFIG REQUIRED)
endif()
# cpp-httplib (libcpp-httplib-dev: a shared library plus httplib.h) for `pbdam serve` and its tests.
pkg_check_modules(HTTPLIB REQUIRED IMPORTED_TARGET cpp-httplib)
