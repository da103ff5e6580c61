# Install tree, exported targets, cuefusionConfig.cmake and the Debian package.
include(CMakePackageConfigHelpers)

set(CUEFUSION_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/cuefusion)
set(CUEFUSION_INSTALL_DATADIR ${CMAKE_INSTALL_DATADIR}/cuefusion)

# cuefusion::cuefusion: every module.
get_property(_cuefusion_modules GLOBAL PROPERTY CUEFUSION_MODULES)
add_library(cuefusion_all INTERFACE)
add_library(cuefusion::cuefusion ALIAS cuefusion_all)
target_link_libraries(cuefusion_all INTERFACE ${_cuefusion_modules})
set_target_properties(cuefusion_all PROPERTIES EXPORT_NAME cuefusion)

install(TARGETS cuefusion_all EXPORT cuefusionTargets)
install(TARGETS cuefusion RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/include/cuefusion DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
# The data files the library and the commands read (scenes, class lists, the network);
# the training logs stay in the source tree.
install(DIRECTORY ${PROJECT_SOURCE_DIR}/data/ DESTINATION ${CUEFUSION_INSTALL_DATADIR}
        PATTERN "*.log.json" EXCLUDE)

# The licence: BSD-3-Clause (LICENSE), where Debian looks for it.
install(FILES ${PROJECT_SOURCE_DIR}/LICENSE DESTINATION ${CMAKE_INSTALL_DOCDIR} RENAME copyright)

install(EXPORT cuefusionTargets NAMESPACE cuefusion:: DESTINATION ${CUEFUSION_INSTALL_CMAKEDIR})
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/cuefusionConfig.cmake.in
  ${PROJECT_BINARY_DIR}/cuefusionConfig.cmake
  INSTALL_DESTINATION ${CUEFUSION_INSTALL_CMAKEDIR}
  PATH_VARS CUEFUSION_INSTALL_DATADIR)
write_basic_package_version_file(${PROJECT_BINARY_DIR}/cuefusionConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES
  ${PROJECT_BINARY_DIR}/cuefusionConfig.cmake
  ${PROJECT_BINARY_DIR}/cuefusionConfigVersion.cmake
  ${PROJECT_SOURCE_DIR}/cmake/cuefusionDependencies.cmake
  DESTINATION ${CUEFUSION_INSTALL_CMAKEDIR})

# cpack -G DEB (in the build folder): one package, cuefusion_<version>_amd64.deb, with the
# libraries, the command, the data, the headers and the CMake config. The run-time
# libraries it needs come from dpkg-shlibdeps (libpcl-*1.13, libopencv-*406, Boost, ...);
# find_package(cuefusion) also needs the development packages of the dependencies.
set(CPACK_PACKAGE_NAME cuefusion)
set(CPACK_PACKAGE_VENDOR "cuefusion")
set(CPACK_PACKAGE_CONTACT "cuefusion developers <cuefusion@localhost>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "Incremental object-level RGB-D mapping that fuses geometric and instance cues (PCL)")
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_RESOURCE_FILE_LICENSE ${PROJECT_SOURCE_DIR}/LICENSE)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS_PRIVATE_DIRS ${PROJECT_BINARY_DIR}/lib)
set(CPACK_DEBIAN_PACKAGE_DEPENDS
  "libpcl-dev (>= 1.13), libopencv-dev, libeigen3-dev, libboost-filesystem-dev, libboost-program-options-dev, nlohmann-json3-dev")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_GENERATOR DEB)
include(CPack)
