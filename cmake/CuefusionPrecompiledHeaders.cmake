# Precompiled headers: most of a cuefusion file's compile time is spent parsing the same
# third-party headers (pcl/point_types.h alone takes 2.5 s), so they are parsed once per
# group of targets built with the same options. Only stable third-party and standard
# headers go in: cuefusion's own headers are parsed per file, so editing one rebuilds
# what includes it and nothing else. Every file still includes what it uses (the
# installed headers and the examples are compiled without precompiled headers:
# test/install). GCC uses a precompiled header only where the file's options match
# (position-independent code, sanitizers, every macro it was built with) and says so
# when it cannot (-Winvalid-pch), so a mismatch costs time, never correctness.
option(CUEFUSION_PRECOMPILE_HEADERS "Precompile the third-party headers (faster builds)" ON)

set(CUEFUSION_PRECOMPILED_HEADERS
  <algorithm> <array> <cmath> <cstdint> <functional> <map> <memory> <optional> <set>
  <sstream> <string> <vector>
  <Eigen/Core> <Eigen/Geometry> <opencv2/core.hpp> <opencv2/imgproc.hpp>
  <pcl/point_cloud.h> <pcl/point_types.h> <boost/filesystem.hpp> <nlohmann/json.hpp>)

# cuefusion_precompile_headers(TARGET GROUP): TARGET uses the headers precompiled for
# GROUP: `library` (position-independent: the modules, the command's libraries) or `test`
# (the test programs, with GoogleTest's header); the command's executable and the fuzz
# and benchmark programs have too few files to gain from one. Each group's
# headers are built by an object library of its own, cuefusion_pch_GROUP, with no macros
# of its own: GCC refuses a precompiled header built with a macro the file lacks (a
# target's private definitions, CMake's NAME_EXPORTS), and accepts one built with fewer.
function(cuefusion_precompile_headers target group)
  if(NOT CUEFUSION_PRECOMPILE_HEADERS)
    return()
  endif()
  set(owner cuefusion_pch_${group})
  if(NOT TARGET ${owner})
    set(source ${PROJECT_BINARY_DIR}/pch/${group}.cpp)
    file(WRITE ${source} "// Built only for the precompiled headers of the ${group} group.\n")
    add_library(${owner} OBJECT ${source})
    target_link_libraries(${owner} PRIVATE
      Eigen3::Eigen ${OpenCV_LIBS} ${CUEFUSION_PCL} Boost::filesystem nlohmann_json::nlohmann_json)
    set(headers ${CUEFUSION_PRECOMPILED_HEADERS})
    if(group STREQUAL "library")
      set_target_properties(${owner} PROPERTIES POSITION_INDEPENDENT_CODE ON)
    elseif(group STREQUAL "test")
      target_link_libraries(${owner} PRIVATE GTest::gtest)
      list(APPEND headers <gtest/gtest.h>)
    endif()
    target_precompile_headers(${owner} PRIVATE ${headers})
  endif()
  target_precompile_headers(${target} REUSE_FROM ${owner})
  target_compile_options(${target} PRIVATE -Winvalid-pch)
endfunction()
