# The packages cuefusion's targets link, and cuefusion::pcl, one target for PCL's
# variables. One list for both users: the build (CuefusionDependencies.cmake) and the
# installed cuefusionConfig.cmake (which sets CUEFUSION_FIND_AS_DEPENDENCY so that a
# missing package fails find_package(cuefusion) the way find_dependency does).
# All of them come from Debian packages (scripts/setup installs them).
include(CMakeFindDependencyMacro)
macro(cuefusion_find_dependency name)
  if(CUEFUSION_FIND_AS_DEPENDENCY)
    find_dependency(${name} ${ARGN})
  else()
    find_package(${name} ${ARGN} REQUIRED)
  endif()
endmacro()

cuefusion_find_dependency(PCL 1.13 COMPONENTS common io filters features sample_consensus segmentation)
set(CUEFUSION_PCL_INCLUDE_DIRS ${PCL_INCLUDE_DIRS})
set(CUEFUSION_PCL_LIBRARIES ${PCL_LIBRARIES})
set(CUEFUSION_PCL_DEFINITIONS ${PCL_DEFINITIONS})
cuefusion_find_dependency(OpenCV COMPONENTS core imgproc imgcodecs videoio dnn features2d)
cuefusion_find_dependency(Eigen3 3.3 NO_MODULE)
cuefusion_find_dependency(Boost COMPONENTS program_options filesystem)
cuefusion_find_dependency(Threads)
cuefusion_find_dependency(nlohmann_json 3)

# PCL's config gives variables, not one target; the modules link this one instead. In
# the build it is cuefusion_pcl (linked as $<BUILD_INTERFACE:cuefusion_pcl>, not exported);
# an installed config makes cuefusion::pcl from the consumer's own PCL.
if(CUEFUSION_FIND_AS_DEPENDENCY)
  set(_cuefusion_pcl_target cuefusion::pcl)
  set(_cuefusion_pcl_kind INTERFACE IMPORTED)
else()
  set(_cuefusion_pcl_target cuefusion_pcl)
  set(_cuefusion_pcl_kind INTERFACE)
endif()
if(NOT TARGET ${_cuefusion_pcl_target})
  add_library(${_cuefusion_pcl_target} ${_cuefusion_pcl_kind})
  target_include_directories(${_cuefusion_pcl_target} SYSTEM INTERFACE ${CUEFUSION_PCL_INCLUDE_DIRS})
  target_link_libraries(${_cuefusion_pcl_target} INTERFACE ${CUEFUSION_PCL_LIBRARIES})
  target_compile_definitions(${_cuefusion_pcl_target} INTERFACE ${CUEFUSION_PCL_DEFINITIONS})
endif()
set(CUEFUSION_PCL "$<BUILD_INTERFACE:cuefusion_pcl>;$<INSTALL_INTERFACE:cuefusion::pcl>")
