file(REMOVE_RECURSE
  "../runout"
  "../runout.pdb"
  "CMakeFiles/runout.dir/src/main.cpp.o"
  "CMakeFiles/runout.dir/src/main.cpp.o.d"
  "CMakeFiles/runout.dir/src/progress.cpp.o"
  "CMakeFiles/runout.dir/src/progress.cpp.o.d"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/runout.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
