# All dependencies come from Debian packages (scripts/setup installs them).
find_package(PCL 1.13 REQUIRED COMPONENTS common io filters features sample_consensus segmentation)
find_package(OpenCV REQUIRED COMPONENTS core imgproc imgcodecs videoio)
find_package(Eigen3 3.3 REQUIRED NO_MODULE)
find_package(Boost REQUIRED COMPONENTS program_options filesystem)
find_package(Threads REQUIRED)
find_package(nlohmann_json 3 REQUIRED)

# One imported interface target for PCL so module targets can link it like any other.
if(NOT TARGET cuefusion_pcl)
  add_library(cuefusion_pcl INTERFACE)
  target_include_directories(cuefusion_pcl SYSTEM INTERFACE ${PCL_INCLUDE_DIRS})
  target_link_libraries(cuefusion_pcl INTERFACE ${PCL_LIBRARIES})
  target_compile_definitions(cuefusion_pcl INTERFACE ${PCL_DEFINITIONS})
endif()

