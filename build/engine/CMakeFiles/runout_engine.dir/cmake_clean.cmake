file(REMOVE_RECURSE
  "CMakeFiles/runout_engine.dir/src/geometry.cpp.o"
  "CMakeFiles/runout_engine.dir/src/geometry.cpp.o.d"
  "CMakeFiles/runout_engine.dir/src/kernels.cpp.o"
  "CMakeFiles/runout_engine.dir/src/kernels.cpp.o.d"
  "CMakeFiles/runout_engine.dir/src/rheology.cpp.o"
  "CMakeFiles/runout_engine.dir/src/rheology.cpp.o.d"
  "CMakeFiles/runout_engine.dir/src/solver.cpp.o"
  "CMakeFiles/runout_engine.dir/src/solver.cpp.o.d"
  "librunout_engine.a"
  "librunout_engine.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/runout_engine.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
