# CMake generated Testfile for 
# Source directory: /work/main/tests
# Build directory: /work/main/build/tests
# 
# This file includes the relevant testing commands required for 
# testing this directory and lists subdirectories to be tested as well.
include("/work/main/build/tests/engine_kernels_test[1]_include.cmake")
include("/work/main/build/tests/engine_rheology_test[1]_include.cmake")
