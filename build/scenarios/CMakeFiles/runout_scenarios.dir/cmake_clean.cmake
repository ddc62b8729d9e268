file(REMOVE_RECURSE
  "CMakeFiles/runout_scenarios.dir/src/run.cpp.o"
  "CMakeFiles/runout_scenarios.dir/src/run.cpp.o.d"
  "CMakeFiles/runout_scenarios.dir/src/scene.cpp.o"
  "CMakeFiles/runout_scenarios.dir/src/scene.cpp.o.d"
  "librunout_scenarios.a"
  "librunout_scenarios.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/runout_scenarios.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
