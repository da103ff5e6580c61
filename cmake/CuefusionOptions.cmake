option(CUEFUSION_BUILD_TESTS "Build the GoogleTest suites" ON)
# Shared libraries with a versioned SONAME, as other PCL applications link them.
option(BUILD_SHARED_LIBS "Build the cuefusion modules as shared libraries" ON)

# Sanitizer builds (scripts/test --sanitize, --tsan): "address,undefined" or "thread".
# Every target gets the flags; EIGEN_MALLOC_ALREADY_ALIGNED=1 keeps Eigen's allocator
# the one Debian's PCL was built with (under ASan Eigen would otherwise switch to its
# hand-made aligned malloc, and memory PCL allocates would be freed by the other one).
set(CUEFUSION_SANITIZE "" CACHE STRING "Build with sanitizers: address,undefined or thread (empty: none)")
if(CUEFUSION_SANITIZE)
  add_compile_options(-fsanitize=${CUEFUSION_SANITIZE} -fno-omit-frame-pointer -fno-sanitize-recover=all -g1)
  add_link_options(-fsanitize=${CUEFUSION_SANITIZE})
  if(CUEFUSION_SANITIZE MATCHES "undefined")
    # UBSan's checks of every memory access and pointer step that AddressSanitizer or the
    # processor already turns into a report or a crash: null (a null access is ASan's
    # SEGV report), object-size (ASan's bounds are exact), alignment (x86 loads any
    # alignment; Eigen's aligned loads fault), pointer-overflow and vptr (a wrong dynamic
    # type comes from a use after free, which ASan reports). Without them the
    # instrumented build compiles about 30 % faster (file_io.cpp: 23.7 s → 16.4 s, the
    # cost of ASan alone); every other check of -fsanitize=undefined stays.
    add_compile_options(-fno-sanitize=alignment,null,object-size,pointer-overflow,vptr)
  endif()
  if(CUEFUSION_SANITIZE MATCHES "address")
    add_compile_definitions(EIGEN_MALLOC_ALREADY_ALIGNED=1)
  endif()
endif()

# libFuzzer harnesses (fuzz/, scripts/fuzz): clang only; off by default.
option(CUEFUSION_FUZZ "Build the libFuzzer harnesses in fuzz/ (needs clang)" OFF)
if(CUEFUSION_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "CUEFUSION_FUZZ needs clang (CC=clang-14 CXX=clang++-14)")
  endif()
  add_compile_options(-fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer -g1)
  add_link_options(-fsanitize=address,undefined)
  add_compile_definitions(EIGEN_MALLOC_ALREADY_ALIGNED=1)
endif()

# Every shared library and loaded module names all it uses (issue 42): a symbol left
# undefined is a link error here, not a failure when another program loads the library.
# Not with sanitizers, whose run-time lives in the executable and is undefined in the
# libraries by design.
if(NOT CUEFUSION_SANITIZE AND NOT CUEFUSION_FUZZ)
  string(APPEND CMAKE_SHARED_LINKER_FLAGS " -Wl,--no-undefined")
  string(APPEND CMAKE_MODULE_LINKER_FLAGS " -Wl,--no-undefined")
endif()
