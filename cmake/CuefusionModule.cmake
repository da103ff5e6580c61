# cuefusion_add_module(NAME SOURCES ... DEPENDS ...)
# Creates library cuefusion_<NAME> with alias cuefusion::<NAME>.
function(cuefusion_add_module name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPENDS" ${ARGN})
  add_library(cuefusion_${name} ${ARG_SOURCES})
  add_library(cuefusion::${name} ALIAS cuefusion_${name})
  target_include_directories(cuefusion_${name} PUBLIC
    $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/include>)
  target_link_libraries(cuefusion_${name} PUBLIC ${ARG_DEPENDS})
  set_target_properties(cuefusion_${name} PROPERTIES POSITION_INDEPENDENT_CODE ON)
  cuefusion_set_warnings(cuefusion_${name})
endfunction()
