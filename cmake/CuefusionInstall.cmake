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

install(TARGETS cuefusion_all EXPORT cuefusionTargets COMPONENT dev)
install(TARGETS cuefusion RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT command)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/include/cuefusion DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} COMPONENT dev)
# The data files the library and the commands read (scenes, class lists, the network);
# the training logs stay in the source tree.
install(DIRECTORY ${PROJECT_SOURCE_DIR}/data/ DESTINATION ${CUEFUSION_INSTALL_DATADIR} COMPONENT data
        PATTERN "*.log.json" EXCLUDE)

install(EXPORT cuefusionTargets NAMESPACE cuefusion:: DESTINATION ${CUEFUSION_INSTALL_CMAKEDIR} COMPONENT dev)
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
  DESTINATION ${CUEFUSION_INSTALL_CMAKEDIR} COMPONENT dev)

# Debian packages, as Debian splits a library (cpack -G DEB in the build folder makes the
# four; test/install/check_install.sh builds them, installs them into a scratch root and
# runs lintian on them):
#   libcuefusion0.1   the modules' shared libraries (SONAME libcuefusion_*.so.0.1)
#   libcuefusion-dev  headers, CMake config, the .so links; depends on the -dev packages
#                     of PCL, OpenCV, Eigen, Boost and nlohmann-json (the headers use them)
#   cuefusion         the command, its private libraries in /usr/lib/cuefusion, cuefusion(1)
#   cuefusion-data    scenes, class lists and the network (architecture all)
# Each has its copyright (DEP-5, packaging/copyright) and changelog in
# /usr/share/doc/<package>. The packager's address: CUEFUSION_PACKAGE_MAINTAINER.
set(CUEFUSION_PACKAGE_MAINTAINER "cuefusion maintainers <cuefusion-maintainers@users.noreply.github.com>"
    CACHE STRING "Maintainer field of the Debian packages")
set(_cuefusion_abi "${PROJECT_VERSION_MAJOR}.${PROJECT_VERSION_MINOR}")
set(_cuefusion_packages
  runtime "libcuefusion${_cuefusion_abi}"
  dev "libcuefusion-dev"
  command "cuefusion"
  data "cuefusion-data")
if(TARGET cuefusion_python)
  list(APPEND _cuefusion_packages python "python3-cuefusion")
endif()
file(MAKE_DIRECTORY ${PROJECT_BINARY_DIR}/packaging)
add_custom_command(OUTPUT ${PROJECT_BINARY_DIR}/packaging/changelog.gz
  COMMAND gzip -9n < ${PROJECT_SOURCE_DIR}/packaging/changelog > ${PROJECT_BINARY_DIR}/packaging/changelog.gz
  DEPENDS ${PROJECT_SOURCE_DIR}/packaging/changelog)
add_custom_target(cuefusion_changelog ALL DEPENDS ${PROJECT_BINARY_DIR}/packaging/changelog.gz)
while(_cuefusion_packages)
  list(POP_FRONT _cuefusion_packages _component _package)
  string(TOUPPER ${_component} _COMPONENT)
  set(CPACK_DEBIAN_${_COMPONENT}_PACKAGE_NAME ${_package})
  install(FILES ${PROJECT_SOURCE_DIR}/packaging/copyright ${PROJECT_BINARY_DIR}/packaging/changelog.gz
          DESTINATION ${CMAKE_INSTALL_DATAROOTDIR}/doc/${_package} COMPONENT ${_component})
endwhile()

set(CPACK_PACKAGE_NAME cuefusion)
set(CPACK_PACKAGE_VENDOR "cuefusion")
set(CPACK_PACKAGE_CONTACT "${CUEFUSION_PACKAGE_MAINTAINER}")
set(CPACK_DEBIAN_PACKAGE_MAINTAINER "${CUEFUSION_PACKAGE_MAINTAINER}")
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_RESOURCE_FILE_LICENSE ${PROJECT_SOURCE_DIR}/LICENSE)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_COMPONENTS_ALL runtime dev command data)
if(TARGET cuefusion_python)
  list(APPEND CPACK_COMPONENTS_ALL python)
endif()
set(CPACK_STRIP_FILES ON)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
# shlibs: what a package built against the libraries depends on (this exact version).
set(CPACK_DEBIAN_PACKAGE_GENERATE_SHLIBS ON)
set(CPACK_DEBIAN_PACKAGE_GENERATE_SHLIBS_POLICY "=")
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS_PRIVATE_DIRS ${PROJECT_BINARY_DIR}/lib ${PROJECT_BINARY_DIR}/lib/cuefusion)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_GENERATOR DEB)
# The packages name each other by exact version (one build, one ABI).
set(_cuefusion_exact "(= ${PROJECT_VERSION})")
# Descriptions: the first line is the synopsis, the rest the extended description.
set(CPACK_DEBIAN_RUNTIME_PACKAGE_SECTION libs)
set(CPACK_DEBIAN_RUNTIME_PACKAGE_RECOMMENDS "cuefusion-data ${_cuefusion_exact}")
set(CPACK_DEBIAN_RUNTIME_DESCRIPTION "object-level 3D maps from RGB-D sequences (libraries)
cuefusion turns an RGB-D sequence into a 3D map in which every object is its
own labelled segment, frame by frame, by fusing depth edges and concave
creases with instance masks from a network, on the CPU.
.
This package holds the shared libraries: geometric segmentation (PCL-style
classes), tracking, TSDF fusion, the label map, the instance segmenters and
the evaluation.")
# The ldconfig trigger (cpack adds ldconfig calls to postinst and postrm too).
set(CPACK_DEBIAN_RUNTIME_PACKAGE_CONTROL_EXTRA ${PROJECT_SOURCE_DIR}/packaging/triggers)
set(CPACK_DEBIAN_DEV_PACKAGE_SECTION libdevel)
set(CPACK_DEBIAN_DEV_PACKAGE_DEPENDS
  "libcuefusion${_cuefusion_abi} ${_cuefusion_exact}, libpcl-dev (>= 1.13), libopencv-dev, libeigen3-dev, libboost-filesystem-dev, libboost-program-options-dev, nlohmann-json3-dev")
set(CPACK_DEBIAN_DEV_DESCRIPTION "object-level 3D maps from RGB-D sequences (development files)
cuefusion turns an RGB-D sequence into a 3D map in which every object is its
own labelled segment.
.
This package holds the headers, the CMake package configuration
(find_package(cuefusion)) and the links to build against the libraries.")
set(CPACK_DEBIAN_COMMAND_PACKAGE_SECTION science)
set(CPACK_DEBIAN_COMMAND_PACKAGE_DEPENDS "libcuefusion${_cuefusion_abi} ${_cuefusion_exact}, cuefusion-data ${_cuefusion_exact}")
set(CPACK_DEBIAN_COMMAND_PACKAGE_RECOMMENDS "gnuplot-nox, parallel")
set(CPACK_DEBIAN_COMMAND_DESCRIPTION "object-level 3D maps from RGB-D sequences
cuefusion turns an RGB-D sequence (a dataset folder, a recording or a live
OpenNI2 camera) into a 3D map in which every object is its own labelled
segment, by fusing geometry (depth edges, concave creases) with instance
masks from a network, on the CPU.
.
The command generates sequences with exact truth, runs and evaluates them,
segments single frames and renders the maps.")
set(CPACK_DEBIAN_DATA_PACKAGE_SECTION science)
set(CPACK_DEBIAN_DATA_PACKAGE_ARCHITECTURE all)
set(CPACK_DEBIAN_DATA_DESCRIPTION "object-level 3D maps from RGB-D sequences (data)
The procedural scenes cuefusion's generator renders, the class lists of
instance segmenters, and xyz_instances, cuefusion's own depth-only instance
network (ONNX).")
set(CPACK_DEBIAN_PYTHON_PACKAGE_SECTION python)
set(CPACK_DEBIAN_PYTHON_PACKAGE_DEPENDS "libcuefusion${_cuefusion_abi} ${_cuefusion_exact}, python3 (>= ${Python3_VERSION_MAJOR}.${Python3_VERSION_MINOR}), python3 (<< ${Python3_VERSION_MAJOR}.${Python3_VERSION_MINOR}.99), python3-numpy")
set(CPACK_DEBIAN_PYTHON_PACKAGE_RECOMMENDS "cuefusion-data ${_cuefusion_exact}")
set(CPACK_DEBIAN_PYTHON_DESCRIPTION "object-level 3D maps from RGB-D sequences (Python 3)
cuefusion turns an RGB-D sequence into a 3D map in which every object is its
own labelled segment, by fusing geometry with instance masks, on the CPU.
.
This package holds the Python 3 module: import cuefusion, numpy arrays in
and out (frames, masks from any Python detector, the labelled map).")
include(CPack)
