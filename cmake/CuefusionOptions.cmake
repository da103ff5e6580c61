option(CUEFUSION_BUILD_TESTS "Build the GoogleTest suites" ON)
