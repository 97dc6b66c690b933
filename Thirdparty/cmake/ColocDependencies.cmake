# Imported targets for the Debian packages coloc builds against. Every package here is installed
# by scripts/install_deps.sh; a missing one stops configuration with the package to install.
include_guard(GLOBAL)
find_package(PkgConfig REQUIRED)

macro(coloc_require_package name debian_package)
  find_package(${name} ${ARGN} QUIET)
  if(NOT ${name}_FOUND)
    message(FATAL_ERROR "${name} not found: install the Debian package '${debian_package}' "
                        "(scripts/install_deps.sh does this)")
  endif()
endmacro()

coloc_require_package(Eigen3 libeigen3-dev 3.4 NO_MODULE)
coloc_require_package(OpenCV "libopencv-dev libopencv-contrib-dev" 4.5
                      COMPONENTS core imgproc imgcodecs features2d calib3d aruco)
coloc_require_package(Ceres libceres-dev)
coloc_require_package(spdlog libspdlog-dev)
coloc_require_package(CLI11 libcli11-dev)
coloc_require_package(nlohmann_json nlohmann-json3-dev 3.10)
coloc_require_package(pugixml libpugixml-dev)
coloc_require_package(SQLite3 libsqlite3-dev)
coloc_require_package(Threads libc6-dev)
# PCL's config gives variables, not targets: one interface target carries them (SYSTEM, so its
# headers' warnings are not ours).
coloc_require_package(PCL libpcl-dev 1.12 COMPONENTS common kdtree)
add_library(coloc_pcl INTERFACE)
target_include_directories(coloc_pcl SYSTEM INTERFACE ${PCL_INCLUDE_DIRS})
target_link_libraries(coloc_pcl INTERFACE ${PCL_LIBRARIES})
add_library(coloc::pcl ALIAS coloc_pcl)
# PCL's registration pieces (FPFH, ICP: registration/align/global_registration), linked by their
# libraries alone: through PCL's config they would drag VTK and Qt into every link, which
# nothing here uses (the libraries themselves do not need them).
set(pcl_registration_libraries "")
foreach(component features registration filters search sample_consensus octree)
  find_library(COLOC_PCL_${component} NAMES pcl_${component} REQUIRED)
  list(APPEND pcl_registration_libraries ${COLOC_PCL_${component}})
endforeach()
add_library(coloc_pcl_registration INTERFACE)
target_link_libraries(coloc_pcl_registration INTERFACE coloc_pcl ${pcl_registration_libraries})
add_library(coloc::pcl_registration ALIAS coloc_pcl_registration)
coloc_require_package(yaml-cpp libyaml-cpp-dev)

# liblo and OSMesa ship only pkg-config files on Debian.
pkg_check_modules(LIBLO IMPORTED_TARGET liblo>=0.31)
if(NOT LIBLO_FOUND)
  message(FATAL_ERROR "liblo not found: install the Debian package 'liblo-dev'")
endif()
add_library(coloc::liblo ALIAS PkgConfig::LIBLO)

pkg_check_modules(OSMESA IMPORTED_TARGET osmesa)
if(NOT OSMESA_FOUND)
  message(FATAL_ERROR "OSMesa not found: install the Debian package 'libosmesa6-dev'")
endif()
add_library(coloc::osmesa ALIAS PkgConfig::OSMESA)

# cpp-httplib (the viewer's server, slam/view): Debian builds it as a shared library whose
# pkg-config file carries the feature macros the header must be compiled with.
pkg_check_modules(HTTPLIB IMPORTED_TARGET cpp-httplib>=0.11)
if(NOT HTTPLIB_FOUND)
  message(FATAL_ERROR "cpp-httplib not found: install the Debian package 'libcpp-httplib-dev'")
endif()
add_library(coloc::httplib ALIAS PkgConfig::HTTPLIB)

if(COLOC_BUILD_TESTS)
  coloc_require_package(GTest "libgtest-dev libgmock-dev")
endif()
if(COLOC_BUILD_BENCHMARKS)
  coloc_require_package(benchmark libbenchmark-dev)
endif()
