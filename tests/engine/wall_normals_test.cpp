// Wall normals of fixed wall particles (engine/src/solver/wall_normals.cpp): the axis along which a particle's
// wall neighbours within 2h spread least. The extrapolated wall pressure's hydrostatic term acts along it, so
// a wrong axis would give a bed or a wall a hydrostatic gradient along itself.
#include <gtest/gtest.h>

#include <cmath>

#include "runout/engine/solver.hpp"

using namespace runout;

namespace {

constexpr double kDp = 0.1;

template <int D>
SceneSetup<D> base() {
  SceneSetup<D> s;
  s.config.dp = kDp;
  s.config.smoothing_length = 1.5 * kDp;
  s.config.speed_of_sound = 20;
  s.config.boundary_pressure = BoundaryPressure::extrapolated;
  for (int d = 0; d < D; ++d) s.config.domain_min[d] = -2, s.config.domain_max[d] = 4;
  MaterialParams water;
  water.name = "water";
  water.set("viscosity", 1e-3);
  s.materials.push_back(water);
  return s;
}

template <int D>
Vec<D> normal_of(const Solver<D>& solver, size_t b) {
  Vec<D> n;
  for (int d = 0; d < D; ++d) n[d] = solver.boundary_normal()[d][b];
  return n;
}

// |n . axis| = 1 within tol (the sign is arbitrary).
template <int D>
void expect_axis(const Vec<D>& n, const Vec<D>& axis, double tol, const std::string& what) {
  EXPECT_NEAR(std::abs(n.dot(axis.normalized())), 1.0, tol) << what << ": n = " << n.transpose();
}

}  // namespace

// A 2D box of three layers: away from the corners, bed particles have a vertical normal and side-wall
// particles a horizontal one, on every layer (the middle layer's neighbours are symmetric across it, yet they
// spread widest along the wall).
TEST(WallNormals, BedAndSideWallsOfABox) {
  SceneSetup<2> s = base<2>();
  for (int i = -3; i < 33; ++i)
    for (int q = 0; q < 3; ++q) s.boundary.add(Vec<2>((i + 0.5) * kDp, -(q + 0.5) * kDp), 1000, 10, 0, 1);
  for (int k = 0; k < 20; ++k)
    for (int q = 0; q < 3; ++q)
      for (double x0 : {-(q + 0.5) * kDp, (30 + q + 0.5) * kDp}) s.boundary.add(Vec<2>(x0, (k + 0.5) * kDp), 1000, 10, 0, 1);
  s.fluid.add(Vec<2>(1.5, 0.05), 1000, 10, 0, 0);
  Solver<2> solver(s);
  const auto& B = solver.boundary();
  int beds = 0, sides = 0;
  for (size_t b = 0; b < B.size(); ++b) {
    const Vec<2> x = B.position(b);
    const Vec<2> n = normal_of(solver, b);
    if (x[1] < 0 && x[0] > 0.5 && x[0] < 2.5) expect_axis<2>(n, Vec<2>(0, 1), 1e-9, "bed"), ++beds;
    if (x[1] > 0.5 && x[1] < 1.5) expect_axis<2>(n, Vec<2>(1, 0), 1e-9, "side wall"), ++sides;
  }
  EXPECT_GT(beds, 50);
  EXPECT_GT(sides, 50);
}

// A 3D bed of three layers inclined at 30 degrees about y, laid on a rotated lattice, periodic along y: the
// normal is the plane's, also at the periodic seam.
TEST(WallNormals, InclinedPlaneWithAPeriodicAxis) {
  SceneSetup<3> s = base<3>();
  s.config.periodic = {false, true, false};
  s.config.domain_min = {-2, 0, -3};
  s.config.domain_max = {4, 1.0, 3};
  const double a = 30 * kPi / 180;
  const Vec<3> along(std::cos(a), 0, -std::sin(a)), up(std::sin(a), 0, std::cos(a));
  for (int i = 0; i < 30; ++i)
    for (int j = 0; j < 10; ++j)
      for (int q = 0; q < 3; ++q)
        s.boundary.add((i + 0.5) * kDp * along + Vec<3>(0, (j + 0.5) * kDp, 0) - (q + 0.5) * kDp * up, 1000, 1, 0, 1);
  s.fluid.add(1.5 * along + Vec<3>(0, 0.5, 0) + 0.05 * up, 1000, 1, 0, 0);
  Solver<3> solver(s);
  const auto& B = solver.boundary();
  int checked = 0;
  for (size_t b = 0; b < B.size(); ++b) {
    const double s_along = B.position(b).dot(along);
    if (s_along < 0.5 || s_along > 2.5) continue;  // away from the plane's two ends
    expect_axis<3>(normal_of(solver, b), up, 1e-9, "inclined bed");
    ++checked;
  }
  EXPECT_GT(checked, 400);
}

// Normals a scene gives are kept (normalised); a zero one is estimated.
TEST(WallNormals, GivenNormalsAreKept) {
  SceneSetup<2> s = base<2>();
  for (int i = 0; i < 20; ++i)
    for (int q = 0; q < 2; ++q) s.boundary.add(Vec<2>((i + 0.5) * kDp, -(q + 0.5) * kDp), 1000, 10, 0, 1);
  s.boundary_normals.assign(s.boundary.size(), Vec<2>(0, 3));
  s.boundary_normals[0] = Vec<2>(3, 4);
  s.boundary_normals[1] = Vec<2>::Zero();
  s.fluid.add(Vec<2>(1.0, 0.05), 1000, 10, 0, 0);
  Solver<2> solver(s);
  const auto& B = solver.boundary();
  for (size_t b = 0; b < B.size(); ++b) {
    const Vec<2> n = normal_of(solver, b);
    if (B.id[b] == 0) EXPECT_NEAR((n - Vec<2>(0.6, 0.8)).norm(), 0, 1e-12);
    if (B.id[b] > 1) EXPECT_NEAR((n - Vec<2>(0, 1)).norm(), 0, 1e-12);
    if (B.id[b] == 1) EXPECT_NEAR(n.norm(), 0, 1e-12);  // estimated from itself alone: no neighbours, no normal
  }
  s.boundary_normals.pop_back();
  EXPECT_THROW(Solver<2>{s}, std::invalid_argument);
}
