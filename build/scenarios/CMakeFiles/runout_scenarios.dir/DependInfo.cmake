
# Consider dependencies only in project.
set(CMAKE_DEPENDS_IN_PROJECT_ONLY OFF)

# The set of languages for which implicit dependencies are needed:
set(CMAKE_DEPENDS_LANGUAGES
  )

# The set of dependency files which are needed:
set(CMAKE_DEPENDS_DEPENDENCY_FILES
  "/work/main/scenarios/src/run.cpp" "scenarios/CMakeFiles/runout_scenarios.dir/src/run.cpp.o" "gcc" "scenarios/CMakeFiles/runout_scenarios.dir/src/run.cpp.o.d"
  "/work/main/scenarios/src/scene.cpp" "scenarios/CMakeFiles/runout_scenarios.dir/src/scene.cpp.o" "gcc" "scenarios/CMakeFiles/runout_scenarios.dir/src/scene.cpp.o.d"
  )

# Targets to which this target links.
set(CMAKE_TARGET_LINKED_INFO_FILES
  "/work/main/build/engine/CMakeFiles/runout_engine.dir/DependInfo.cmake"
  )

# Fortran module output directory.
set(CMAKE_Fortran_TARGET_MODULE_DIR "")
