# The build's dependencies: the same list the installed config file finds again.
include(${CMAKE_CURRENT_LIST_DIR}/cuefusionDependencies.cmake)
