include(GNUInstallDirs)

# cuefusion_add_module(NAME SOURCES ... DEPENDS ...)
# Creates library cuefusion_<NAME> (shared unless BUILD_SHARED_LIBS is OFF) with alias
# cuefusion::<NAME>, installed and exported under that same name (cuefusionTargets).
function(cuefusion_add_module name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPENDS" ${ARGN})
  add_library(cuefusion_${name} ${ARG_SOURCES})
  add_library(cuefusion::${name} ALIAS cuefusion_${name})
  target_include_directories(cuefusion_${name} PUBLIC
    $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/include>
    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  target_link_libraries(cuefusion_${name} PUBLIC ${ARG_DEPENDS})
  # Before 1.0 every minor version may break the ABI, so it is part of the SONAME.
  set_target_properties(cuefusion_${name} PROPERTIES
    POSITION_INDEPENDENT_CODE ON
    LIBRARY_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/lib
    ARCHIVE_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/lib
    EXPORT_NAME ${name}
    VERSION ${PROJECT_VERSION}
    SOVERSION ${PROJECT_VERSION_MAJOR}.${PROJECT_VERSION_MINOR})
  cuefusion_set_warnings(cuefusion_${name})
  cuefusion_precompile_headers(cuefusion_${name} library)
  # Packages (CuefusionInstall.cmake): the versioned library in libcuefusion<M.m>
  # ("runtime"), the unversioned link and static archives in libcuefusion-dev ("dev").
  install(TARGETS cuefusion_${name} EXPORT cuefusionTargets
    LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT runtime NAMELINK_COMPONENT dev
    ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT dev
    RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT runtime)
  set_property(GLOBAL APPEND PROPERTY CUEFUSION_MODULES cuefusion_${name})
endfunction()

# Where the library finds data/ (scenes, class lists, models) once installed: relative to
# the directory holding the library, so an installed tree or package can be moved.
file(RELATIVE_PATH CUEFUSION_DATA_FROM_LIBDIR "${CMAKE_INSTALL_FULL_LIBDIR}"
     "${CMAKE_INSTALL_FULL_DATADIR}/cuefusion")
file(RELATIVE_PATH CUEFUSION_LIBDIR_FROM_BINDIR "${CMAKE_INSTALL_FULL_BINDIR}" "${CMAKE_INSTALL_FULL_LIBDIR}")
