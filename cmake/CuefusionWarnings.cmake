# Warnings apply to the project's own targets only, never to PCL/VTK headers
# (those are included as SYSTEM so their warnings stay out of our build log).
function(cuefusion_set_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra)
endfunction()
