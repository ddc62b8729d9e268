
# Consider dependencies only in project.
set(CMAKE_DEPENDS_IN_PROJECT_ONLY OFF)

# The set of languages for which implicit dependencies are needed:
set(CMAKE_DEPENDS_LANGUAGES
  )

# The set of dependency files which are needed:
set(CMAKE_DEPENDS_DEPENDENCY_FILES
  "/work/main/engine/src/geometry.cpp" "engine/CMakeFiles/runout_engine.dir/src/geometry.cpp.o" "gcc" "engine/CMakeFiles/runout_engine.dir/src/geometry.cpp.o.d"
  "/work/main/engine/src/kernels.cpp" "engine/CMakeFiles/runout_engine.dir/src/kernels.cpp.o" "gcc" "engine/CMakeFiles/runout_engine.dir/src/kernels.cpp.o.d"
  "/work/main/engine/src/rheology.cpp" "engine/CMakeFiles/runout_engine.dir/src/rheology.cpp.o" "gcc" "engine/CMakeFiles/runout_engine.dir/src/rheology.cpp.o.d"
  "/work/main/engine/src/solver.cpp" "engine/CMakeFiles/runout_engine.dir/src/solver.cpp.o" "gcc" "engine/CMakeFiles/runout_engine.dir/src/solver.cpp.o.d"
  )

# Targets to which this target links.
set(CMAKE_TARGET_LINKED_INFO_FILES
  )

# Fortran module output directory.
set(CMAKE_Fortran_TARGET_MODULE_DIR "")
