// Verlet lists (SolverConfig::neighbour_skin, engine/src/solver/pair_lists.cpp): the cells are sorted and
// scanned for candidates within 2h + skin only now and then, and each force evaluation keeps the candidates
// inside the support. Whatever the flow does (a collapsing column that splashes on a wall, a layer wrapping on a
// periodic axis, particles leaving through an open face), the lists the next evaluation uses must hold every
// pair inside the support: checked by brute force after every step. (Reusing the candidates whatever the flow's
// displacement fails the first two tests and WallTiles.TheNeighbourCandidatesHoldEveryPairInsideTheSupport; the
// factor 2 of the bound, two particles closing in head-on, is a worst case these flows do not reach.)
#include <gtest/gtest.h>

#include <cmath>

#include "runout/engine/solver.hpp"

using namespace runout;

namespace {

constexpr double kDp = 0.02;

enum class Case { closed_box, periodic_layer, open_face };

// 2D water in a box 1 m long with walls three layers deep: a 0.3 x 0.6 m column against the left wall
// (closed_box; open_face opens the right end), or a 0.1 m layer over the whole bed moving at 2 m/s along a
// periodic x axis (periodic_layer).
SceneSetup<2> scene(Case c, double skin) {
  SceneSetup<2> s;
  s.config.dp = kDp;
  s.config.smoothing_length = 1.3 * kDp;
  s.config.speed_of_sound = 25;  // Mach 0.1 at the collapse's ~2.5 m/s front
  s.config.neighbour_skin = skin;
  s.config.boundary_pressure = BoundaryPressure::extrapolated;
  s.config.gravity = {0, -9.81, 0};
  s.config.domain_min = {0, -0.1, 0};
  s.config.domain_max = {1, 2, 0};
  MaterialParams water;
  water.name = "water";
  water.set("viscosity", 1e-3);
  s.materials.push_back(water);
  const double m0 = 1000 * kDp * kDp;
  const int columns = static_cast<int>(std::lround(1.0 / kDp));
  for (int i = (c == Case::periodic_layer ? 0 : -3); i < columns + (c == Case::closed_box ? 3 : 0); ++i)
    for (int q = 0; q < 3; ++q) s.boundary.add(Vec<2>((i + 0.5) * kDp, -(q + 0.5) * kDp), 1000, m0, 0, 1);
  if (c == Case::periodic_layer) {
    s.config.periodic = {true, false, false};
    for (int i = 0; i < columns; ++i)
      for (int j = 0; j < 5; ++j) {
        s.fluid.add(Vec<2>((i + 0.5) * kDp, (j + 0.5) * kDp), 1000, m0, 0, 0);
        s.fluid.vel[0].back() = 2.0;
      }
    return s;
  }
  for (int j = 0; j < 40; ++j)
    for (int q = 0; q < 3; ++q) {
      s.boundary.add(Vec<2>(-(q + 0.5) * kDp, (j + 0.5) * kDp), 1000, m0, 0, 1);
      if (c == Case::closed_box) s.boundary.add(Vec<2>(1 + (q + 0.5) * kDp, (j + 0.5) * kDp), 1000, m0, 0, 1);
    }
  if (c == Case::open_face) s.config.outflow[0][1] = true;
  for (int i = 0; i < 15; ++i)
    for (int j = 0; j < 30; ++j) s.fluid.add(Vec<2>((i + 0.5) * kDp, (j + 0.5) * kDp), 1000, m0, 0, 0);
  return s;
}

struct Outcome {
  size_t missing = 0;
  long steps = 0, builds = 0;
  size_t fluid_left = 0;
  long double mass_error = 0;
};

Outcome run(Case c, double skin, double seconds) {
  Solver<2> solver(scene(c, skin));
  Outcome o;
  while (solver.time() < seconds) {
    solver.step();
    o.missing += solver.missing_neighbour_pairs();
  }
  o.steps = solver.steps();
  o.builds = solver.neighbour_list_builds();
  o.fluid_left = solver.fluid().size();
  const MassBalance m = solver.mass_balance();
  o.mass_error = std::abs(m.total_current() + m.total_outflow() - m.total_initial()) / m.total_initial();
  return o;
}

}  // namespace

// The limits on the scan count follow from the rebuild rule, not from a run: at Mach <= 0.1 and cfl 0.2 a particle
// moves at most 0.02 h a step, so candidates with a 0.3 h skin last at least (0.15 - 0.01) / 0.02 = 7 steps for
// the fastest pair (fewer than half the steps scanned); and a front that runs ~0.7 m moves ~90 skins (0.0078 m),
// so the cells must be sorted again many times (more than 5).
// The column collapses, runs along the bed at up to ~2.5 m/s and splashes up the far wall in 0.6 s.
TEST(NeighbourLists, ACollapsingColumnKeepsEveryPairInsideTheSupport) {
  const Outcome o = run(Case::closed_box, 0.3, 0.6);
  EXPECT_EQ(o.missing, 0u);
  EXPECT_LT(o.builds, o.steps / 2) << "the candidates should outlive a step";
  EXPECT_GT(o.builds, 5) << "the flow moves more than the skin: the cells must be sorted again";
}

// Each particle wraps about once in 0.5 s: a wrap sorts the cells again.
TEST(NeighbourLists, ALayerWrappingOnAPeriodicAxisKeepsEveryPair) {
  const Outcome o = run(Case::periodic_layer, 0.3, 0.5);
  EXPECT_EQ(o.missing, 0u);
  EXPECT_LT(o.builds, o.steps / 2);
  EXPECT_LT(o.mass_error, 1e-12);
}

// Particles leave through the open right end from about 0.4 s: the sort that removes them comes at the step
// they cross, with or without a skin, and the mass balance stays exact.
TEST(NeighbourLists, ParticlesLeavingThroughAnOpenFaceAreRemovedAndCounted) {
  for (double skin : {0.0, 0.3}) {
    const Outcome o = run(Case::open_face, skin, 0.8);
    EXPECT_EQ(o.missing, 0u);
    EXPECT_LT(o.fluid_left, 450u) << "some flow should have left (skin " << skin << ")";
    EXPECT_LT(o.mass_error, 1e-12);
  }
}

// Out of range: a clear error naming the field.
TEST(NeighbourLists, ASkinOutOfRangeIsRefused) {
  try {
    Solver<2> solver(scene(Case::closed_box, 1.5));
    FAIL() << "a skin of 1.5 h was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("neighbour_skin"), std::string::npos) << e.what();
  }
}
