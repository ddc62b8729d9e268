// Wall particles laid near the flow (wall_source.hpp): a block of water slides fast over a flat bed given as a
// wall source. The walls it needs are there at every step, the run is the same, bit for bit, as with the whole
// bed laid at the start, and only a small part of the bed is ever alive.
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <set>
#include <sstream>

#include "runout/engine/solver.hpp"

using namespace runout;

namespace {

constexpr double kDp = 0.1;
constexpr int kColumns = 150, kRows = 12, kLayers = 3, kTile = 2;

// A flat bed at z = 0: kColumns x kRows columns of `layers` particles, in tiles of kTile x kTile columns, each
// tile one slab of a layer when cut in depth (top down; ids in the order of the tiles).
class PlaneSource final : public WallSource<3> {
 public:
  explicit PlaneSource(int layers = kLayers, bool cut_in_depth = false) : layers_(layers), cut_(cut_in_depth) {}
  WallTileGrid tiles() const override {
    WallTileGrid g;
    g.size = kTile * kDp;
    g.nx = kColumns / kTile;
    g.ny = kRows / kTile;
    if (cut_) {
      g.slab = kDp;  // one layer a slab: its particles at one height
      g.slab_extent = 0;
      g.spread = 0.5 - 0.5 / kTile;  // a tile's particles sit half a column inside it
      for (int64_t k = 0; k <= g.columns(); ++k) g.column_first.push_back(k * layers_);
      g.column_top.assign(static_cast<size_t>(g.columns()), -0.5 * kDp);
    }
    return g;
  }
  void lay(int64_t t, std::vector<Vec<3>>& pos, std::vector<Vec<3>>& normals, std::vector<uint32_t>& tags) const override {
    const int64_t column = cut_ ? t / layers_ : t;
    const int q0 = cut_ ? static_cast<int>(t % layers_) : 0, q1 = cut_ ? q0 + 1 : layers_;
    const int64_t ix = column % (kColumns / kTile), iy = column / (kColumns / kTile);
    for (int64_t j = iy * kTile; j < (iy + 1) * kTile; ++j)
      for (int64_t i = ix * kTile; i < (ix + 1) * kTile; ++i)
        for (int q = q0; q < q1; ++q) {
          pos.push_back(Vec<3>((i + 0.5) * kDp, (j + 0.5) * kDp, -(q + 0.5) * kDp));
          normals.push_back(Vec<3>::UnitZ());
          tags.push_back(1);
        }
  }
  uint64_t first_index(int64_t t) const override {
    return static_cast<uint64_t>(t) * kTile * kTile * (cut_ ? 1 : layers_);
  }
  uint64_t total() const override { return uint64_t{kColumns} * kRows * layers_; }
  Vec<3> lowest() const override { return Vec<3>(0.5 * kDp, 0.5 * kDp, -(layers_ - 0.5) * kDp); }

 private:
  int layers_;
  bool cut_;
};

// Water 0.6 x 0.6 x 0.3 m sliding along +x at 6 m/s over the bed, with side walls of its own (fixed particles).
SceneSetup<3> sliding_block(bool bed_as_source, BoundaryPressure walls, double neighbour_skin = 0.0,
                            const PlaneSource& plane = PlaneSource()) {
  SceneSetup<3> s;
  s.config.dp = kDp;
  s.config.neighbour_skin = neighbour_skin;
  s.config.smoothing_length = 1.3 * kDp;
  s.config.speed_of_sound = 60;  // Mach 0.1 at the slide's speed
  s.config.boundary_pressure = walls;
  s.config.domain_min = {-1, -1, -1};
  s.config.domain_max = {kColumns * kDp + 1, kRows * kDp + 1, 3};
  MaterialParams water;
  water.name = "water";
  water.set("viscosity", 1e-3);
  s.materials.push_back(water);
  const double m0 = 1000 * std::pow(kDp, 3);  // as the solver gives the tiles it lays
  for (int i = 0; i < kColumns; ++i)  // side walls along the channel: fixed, always alive
    for (int q = 0; q < 4; ++q)
      for (double y : {-0.5 * kDp, (kRows + 0.5) * kDp}) s.boundary.add(Vec<3>((i + 0.5) * kDp, y, (q + 0.5) * kDp), 1000, m0, 0, 2);
  if (bed_as_source) {
    s.wall_source = std::make_shared<PlaneSource>(plane);
  } else {
    std::vector<Vec<3>> pos, normals;
    std::vector<uint32_t> tags;
    for (int64_t t = 0; t < plane.tiles().count(); ++t) plane.lay(t, pos, normals, tags);
    s.boundary_normals.assign(s.boundary.size(), Vec<3>::Zero());  // the side walls': estimated, as with tiles
    for (size_t k = 0; k < pos.size(); ++k) s.boundary.add(pos[k], 1000, m0, 0, tags[k]);
    s.boundary_normals.insert(s.boundary_normals.end(), normals.begin(), normals.end());
  }
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j)
      for (int q = 0; q < 3; ++q) {
        s.fluid.add(Vec<3>((i + 2.5) * kDp, (j + 3.5) * kDp, (q + 0.5) * kDp), 1000, m0, 0, 0);
        s.fluid.vel[0].back() = 6.0;
      }
  return s;
}

// Source particles within the kernel support of some fluid particle that are not alive (by id).
size_t missing_walls(const Solver<3>& solver, const PlaneSource& plane, size_t fixed) {
  std::set<uint32_t> alive(solver.boundary().id.begin(), solver.boundary().id.end());
  const double support = 2 * solver.config().smoothing_length;
  size_t missing = 0;
  std::vector<Vec<3>> pos, normals;
  std::vector<uint32_t> tags;
  for (int64_t t = 0; t < plane.tiles().count(); ++t) {
    pos.clear();
    plane.lay(t, pos, normals, tags);
    for (size_t k = 0; k < pos.size(); ++k) {
      const auto id = static_cast<uint32_t>(fixed + plane.first_index(t) + k);
      if (alive.count(id)) continue;
      for (size_t i = 0; i < solver.fluid().size(); ++i)
        if ((solver.fluid().position(i) - pos[k]).norm() < support) {
          ++missing;
          break;
        }
    }
  }
  return missing;
}

}  // namespace

// The block slides 2.6 mm a step at 6 m/s and crosses a 0.2 m tile edge every ~80 steps, four times in the run:
// after every step, each bed particle within 2h of the flow exists. Laying the walls within 2h of where the
// flow was at the step's start (a step late, no margin) fails this.
TEST(WallTiles, TheWallsAFastFlowNeedsAreThereAtEveryStep) {
  Solver<3> solver(sliding_block(true, BoundaryPressure::extrapolated));
  const PlaneSource plane;
  const size_t fixed = 2 * kColumns * 4;
  ASSERT_EQ(missing_walls(solver, plane, fixed), 0u);
  double x0 = solver.fluid().pos[0][0];
  size_t worst = 0;
  while (solver.time() < 0.12) {
    solver.step();
    worst = std::max(worst, missing_walls(solver, plane, fixed));
  }
  EXPECT_EQ(worst, 0u);
  EXPECT_GT(solver.fluid().pos[0][0] - x0, 0.5) << "the block should have crossed several tiles";
  EXPECT_GT(solver.boundary_generation(), 3u);
}

// The same run with the bed laid whole at the start and laid near the flow: the same particles meet the flow in
// the same order, so the state is identical to the bit (one thread; both wall models).
// With a neighbour skin too: the candidates are scanned again among the walls alive whenever they change, where
// the flow stood at the last sort, so they are those of the bed laid whole.
TEST(WallTiles, LayingTheBedNearTheFlowChangesNothingInTheResult) {
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  for (double skin : {0.0, 0.3})
  for (BoundaryPressure walls : {BoundaryPressure::dbc, BoundaryPressure::extrapolated}) {
    SCOPED_TRACE("neighbour skin " + std::to_string(skin));
    Solver<3> whole(sliding_block(false, walls, skin)), near(sliding_block(true, walls, skin));
    for (int k = 0; k < 400; ++k) {
      whole.step();
      near.step();
    }
    ASSERT_EQ(whole.fluid().size(), near.fluid().size());
    EXPECT_EQ(whole.time(), near.time());
    size_t differ = 0;
    for (size_t i = 0; i < whole.fluid().size(); ++i)
      for (int d = 0; d < 3; ++d)
        differ += whole.fluid().pos[d][i] != near.fluid().pos[d][i] || whole.fluid().vel[d][i] != near.fluid().vel[d][i];
    EXPECT_EQ(differ, 0u) << boundary_pressure_names()[static_cast<int>(walls)];
    // The bed: 5 400 particles; alive near a 108-particle block, a few hundred.
    EXPECT_EQ(whole.boundary_described(), near.boundary_described());
    EXPECT_LT(near.boundary_peak(), whole.boundary().size() / 3);
    if (skin > 0) {
      EXPECT_LT(whole.neighbour_list_builds(), 400 / 2) << "the candidates should outlive a step";
    }
  }
  omp_set_num_threads(threads);
}

// A bed ten layers deep, cut in depth a layer a tile: the block (its lowest particles at z = dp / 2) needs
// none of the layers more than its support 2h = 0.26 m below it, so none under z = -0.5 m (more than twice
// the support below the flow, margin for the reach's motion allowance) is ever alive, while every bed
// particle within 2h of the flow is, at every step, and the run is the bed laid whole's to the bit (one thread).
TEST(WallTiles, ABedCutInDepthLaysOnlyTheLayersWithinReach) {
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  const PlaneSource deep(10, true);
  for (BoundaryPressure walls : {BoundaryPressure::dbc, BoundaryPressure::extrapolated}) {
    SCOPED_TRACE(boundary_pressure_names()[static_cast<int>(walls)]);
    Solver<3> whole(sliding_block(false, walls, 0.3, deep)), near(sliding_block(true, walls, 0.3, deep));
    const size_t fixed = 2 * kColumns * 4;
    size_t worst_missing = 0;
    double deepest = 0;
    for (int k = 0; k < 300; ++k) {
      whole.step();
      near.step();
      worst_missing = std::max(worst_missing, missing_walls(near, deep, fixed));
      for (size_t b = 0; b < near.boundary().size(); ++b)
        if (near.boundary().id[b] >= fixed) deepest = std::min(deepest, near.boundary().pos[2][b]);
    }
    EXPECT_EQ(worst_missing, 0u);
    EXPECT_GT(deepest, -0.5);
    EXPECT_GT(near.boundary_generation(), 1u) << "the walls alive should change as the block slides";
    size_t differ = 0;
    for (size_t i = 0; i < whole.fluid().size(); ++i)
      for (int d = 0; d < 3; ++d)
        differ += whole.fluid().pos[d][i] != near.fluid().pos[d][i] || whole.fluid().vel[d][i] != near.fluid().vel[d][i];
    EXPECT_EQ(differ, 0u);
  }
  omp_set_num_threads(threads);
}

TEST(WallTiles, MoreParticlesAliveThanTheLimitStopsTheRunNamingIt) {
  SceneSetup<3> s = sliding_block(true, BoundaryPressure::dbc);
  s.max_particles = static_cast<long>(s.fluid.size() + s.boundary.size()) + 10;
  try {
    Solver<3> solver(std::move(s));
    FAIL() << "expected the limit to stop the run";
  } catch (const SimulationError& e) {
    EXPECT_NE(std::string(e.what()).find("limits.max_particles"), std::string::npos) << e.what();
  }
}

// Deterministic: the tiles laid, their order and the run repeat bit for bit (one thread).
TEST(WallTiles, TwoRunsLayTheSameTilesAndGiveTheSameBits) {
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  Solver<3> a(sliding_block(true, BoundaryPressure::dbc)), b(sliding_block(true, BoundaryPressure::dbc));
  for (int k = 0; k < 300; ++k) {
    a.step();
    b.step();
  }
  omp_set_num_threads(threads);
  EXPECT_EQ(a.boundary_generation(), b.boundary_generation());
  EXPECT_EQ(a.boundary().id, b.boundary().id);
  EXPECT_EQ(a.boundary().rho, b.boundary().rho);
  for (int d = 0; d < 3; ++d) {
    EXPECT_EQ(a.fluid().pos[d], b.fluid().pos[d]);
    EXPECT_EQ(a.fluid().vel[d], b.fluid().vel[d]);
  }
}

// A checkpoint of a run with wall tiles, taken mid-slide and loaded into a solver built afresh, continues the
// run bit for bit: the tiles alive then, the walls' densities and the tiles laid after it (one thread).
// With a neighbour skin, the resumed run reuses the candidates where the uninterrupted one does.
TEST(WallTiles, ARunResumedFromACheckpointGivesTheSameBits) {
  for (double skin : {0.0, 0.3}) {
  SCOPED_TRACE("neighbour skin " + std::to_string(skin));
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  Solver<3> a(sliding_block(true, BoundaryPressure::dbc, skin));
  for (int k = 0; k < 120; ++k) a.step();
  std::stringstream saved;
  StateWriter out(saved);
  a.save_state(out);
  Solver<3> b(sliding_block(true, BoundaryPressure::dbc, skin));
  StateReader in(saved);
  b.load_state(in);
  EXPECT_EQ(b.boundary().id, a.boundary().id);
  const uint64_t generation = a.boundary_generation();
  for (int k = 0; k < 180; ++k) {
    a.step();
    b.step();
  }
  omp_set_num_threads(threads);
  EXPECT_GT(a.boundary_generation(), generation);  // tiles were laid after the checkpoint
  EXPECT_EQ(a.time(), b.time());
  EXPECT_EQ(a.steps(), b.steps());
  EXPECT_EQ(a.boundary_generation(), b.boundary_generation());
  EXPECT_EQ(a.boundary_peak(), b.boundary_peak());
  EXPECT_EQ(a.boundary().id, b.boundary().id);
  EXPECT_EQ(a.boundary().rho, b.boundary().rho);
  for (int d = 0; d < 3; ++d) {
    EXPECT_EQ(a.fluid().pos[d], b.fluid().pos[d]);
    EXPECT_EQ(a.fluid().vel[d], b.fluid().vel[d]);
  }
  EXPECT_EQ(a.fluid().rho, b.fluid().rho);
  EXPECT_EQ(a.energy().potential_released, b.energy().potential_released);
  EXPECT_EQ(a.neighbour_list_builds(), b.neighbour_list_builds());
  }
}

// With a neighbour skin, the lists the next evaluation uses hold every fluid and wall pair inside the kernel
// support (a brute-force check after every step), while the block slides at Mach 0.1 and the walls alive change.
TEST(WallTiles, TheNeighbourCandidatesHoldEveryPairInsideTheSupport) {
  Solver<3> solver(sliding_block(true, BoundaryPressure::extrapolated, 0.3));
  size_t missing = 0;
  while (solver.time() < 0.12) {
    solver.step();
    missing += solver.missing_neighbour_pairs();
  }
  EXPECT_EQ(missing, 0u);
  EXPECT_LT(solver.neighbour_list_builds(), solver.steps() / 2);
  EXPECT_GT(solver.boundary_generation(), 3u);
}

// A checkpoint is refused by a solver of another setup, naming what differs.
TEST(WallTiles, ACheckpointOfAnotherSetupIsRefused) {
  Solver<3> a(sliding_block(true, BoundaryPressure::dbc));
  std::stringstream saved;
  StateWriter out(saved);
  a.save_state(out);
  Solver<3> b(sliding_block(false, BoundaryPressure::dbc));  // the bed laid whole: other wall particles
  StateReader in(saved);
  try {
    b.load_state(in);
    FAIL() << "a checkpoint of another setup was loaded";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("wall source"), std::string::npos) << e.what();
  }
}
