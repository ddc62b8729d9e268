#pragma once
// A run's particles for ParaView (docs/design.md, "Snapshots"), in OUT/snapshots/:
//   snapshot_NNNN.vtp  the flow particles at one time, with TimeValue in FieldData
//   walls.vtp          the wall particles that always exist (tanks, blocks, beds, a terrain's structures),
//                      written once: they never move (the engine's boundary is fixed)
//   dem.vts            terrain scenes: the DEM cells over the corridor as a surface, in place of the bed's
//                      particles (those are laid only near the flow and come and go)
//   snapshots.pvd      the index ParaView opens: each frame by time with walls and dem beside it, rewritten
//                      after every frame so a stopped run still has a readable one
// Every file is VTK XML with binary appended data (raw, little-endian, UInt64 block headers). Terrain scenes
// write map coordinates of the working CRS as Float64 (the particles' local frame plus the DEM origin);
// other scenes their own frame as Float32.
#include <filesystem>
#include <string>
#include <vector>

#include "runout/scenarios/scene.hpp"

namespace runout {

template <int D>
class SnapshotWriter {
 public:
  // Creates `dir` and writes walls.vtp, dem.vts (terrain scenes) and an index without frames.
  SnapshotWriter(const Scene& scene, std::filesystem::path dir);
  // Writes snapshot_NNNN.vtp of the solver's flow at its time and rewrites snapshots.pvd.
  void write_frame(const Solver<D>& solver);
  int frames() const { return static_cast<int>(times_.size()); }
  // The frames' times, and the frames written before a checkpoint this run resumed from (rewrites the index).
  const std::vector<double>& times() const { return times_; }
  void resume_after(std::vector<double> times);

 private:
  void write_index() const;

  std::filesystem::path dir_;
  bool map_coordinates_ = false;  // terrain: Float64 points shifted by the DEM origin
  double origin_[3] = {0, 0, 0};
  bool has_dem_ = false;
  std::vector<double> times_;
};

}  // namespace runout
