# `cmake --install`: the CLI, every module library with its public headers, the C ABI libraries,
# the data the CLI needs (share/coloc) and an exported CMake package, so that a project can
# find_package(coloc) and link coloc::coloc. Included last, once every target is known.
include_guard(GLOBAL)
include(CMakePackageConfigHelpers)

get_property(exported GLOBAL PROPERTY COLOC_EXPORTED_TARGETS)
set(static_libraries "")
foreach(target IN LISTS exported)
  get_target_property(type ${target} TYPE)
  if(type STREQUAL "STATIC_LIBRARY")
    list(APPEND static_libraries ${target})
  endif()
endforeach()

# coloc::coloc: every library of the project (the C ABI libraries are separate products).
add_library(coloc_all INTERFACE)
set_target_properties(coloc_all PROPERTIES EXPORT_NAME coloc)
target_link_libraries(coloc_all INTERFACE ${static_libraries})
add_library(coloc::coloc ALIAS coloc_all)

install(TARGETS coloc RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(TARGETS ${exported} coloc_all coloc_pcl coloc_pcl_registration
        EXPORT colocTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
        RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
# Headers keep their repository paths ("slam/core/se3.hpp") under include/coloc.
install(DIRECTORY ${PROJECT_SOURCE_DIR}/slam ${PROJECT_SOURCE_DIR}/e57io
                  ${PROJECT_SOURCE_DIR}/fusion ${PROJECT_SOURCE_DIR}/markers
                  ${PROJECT_SOURCE_DIR}/registration
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/coloc
        FILES_MATCHING PATTERN "*.hpp" PATTERN "*.h"
        PATTERN "node_modules" EXCLUDE)
set(COLOC_INSTALL_DATADIR ${CMAKE_INSTALL_DATADIR}/coloc)
install(DIRECTORY ${COLOC_STAGE_DIR}/ DESTINATION ${COLOC_INSTALL_DATADIR})
install(FILES ${PROJECT_SOURCE_DIR}/LICENSE DESTINATION ${CMAKE_INSTALL_DOCDIR} OPTIONAL)

set(package_dir ${CMAKE_INSTALL_LIBDIR}/cmake/coloc)
install(EXPORT colocTargets NAMESPACE coloc:: DESTINATION ${package_dir})
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/colocConfig.cmake.in
                              ${CMAKE_BINARY_DIR}/colocConfig.cmake
                              INSTALL_DESTINATION ${package_dir}
                              PATH_VARS COLOC_INSTALL_DATADIR)
# 0.x: a minor release may break the API, so only the same minor version is compatible.
write_basic_package_version_file(${CMAKE_BINARY_DIR}/colocConfigVersion.cmake
                                 COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_BINARY_DIR}/colocConfig.cmake ${CMAKE_BINARY_DIR}/colocConfigVersion.cmake
        DESTINATION ${package_dir})

# scripts/package: a .deb through CPack. Its dependencies are the Debian packages of the
# shared libraries the binaries link (dpkg-shlibdeps), plus the -dev packages a consumer of
# the headers and static libraries needs (scripts/install_deps.sh installs the same).
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME coloc)
set(CPACK_PACKAGE_VENDOR "coloc")
set(CPACK_PACKAGE_CONTACT "coloc developers <coloc@localhost>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY
    "Co-location of XR users with a laser-scanned building (RGB-D SLAM, E57, registration)")
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_DEPENDS
    "libeigen3-dev, libopencv-dev, libopencv-contrib-dev, libceres-dev, libsuitesparse-dev, \
libosmesa6-dev, libsqlite3-dev, libpcl-dev, liblo-dev, libyaml-cpp-dev, libspdlog-dev, \
libpugixml-dev, nlohmann-json3-dev, libcpp-httplib-dev")
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS "python3-matplotlib, chromium")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
include(CPack)
