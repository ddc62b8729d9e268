// The bend profiles of the stopping-on-terrain tests (tests/scenarios/energy_line_test.cpp on the 3D engine,
// tests/scenarios/screening_run_test.cpp on the screening rung: the same scenes, so the rungs compare), and the
// rigid Coulomb block's stop on them with the bend's centripetal load.
#pragma once

#include <cmath>

namespace runout_test {

// A face, a concave circular bend tangent to it and to the runout, the runout; the release on the face. The
// ground falls east from `top` at x = 0 (the DEM's west edge).
struct BendProfile {
  const char* name;
  double face_deg, face_end, radius, runout_deg;  // [deg], [m], [m], [deg]
  double release_from, release_to;                // [m] along x
  double top = 300.0;                             // [m] the ground at x = 0
  static constexpr double kDeg = M_PI / 180;
  double centre() const { return face_end + radius * std::sin(face_deg * kDeg); }
  double bend_end() const { return centre() - radius * std::sin(runout_deg * kDeg); }
  double ground(double x) const {
    const double z_face_end = top - std::tan(face_deg * kDeg) * face_end;
    const double zc = z_face_end + radius * std::cos(face_deg * kDeg), xc = centre();
    if (x <= face_end) return top - std::tan(face_deg * kDeg) * x;
    if (x <= bend_end()) return zc - std::sqrt(radius * radius - (x - xc) * (x - xc));
    return zc - radius * std::cos(runout_deg * kDeg) - std::tan(runout_deg * kDeg) * (x - bend_end());
  }
  double curvature(double x) const { return x > face_end && x <= bend_end() ? 1.0 / radius : 0.0; }
};

// Scene A (declared first) and B (declared after A's 3D run, before its own): docs/validation.md section 10.
inline const BendProfile kBendA{"a", 30, 60, 120, 10, 10, 30};
inline const BendProfile kBendB{"b", 35, 50, 60, 10, 5, 25};

// The rigid block's travel with the bend's centripetal load: per horizontal dx, d(v^2/2) = g tan(theta) dx -
// mu (g + v^2 k / cos(theta)) dx, from rest at x0 until v = 0 or x = length (explicit steps of 1 mm).
inline double block_reach(const BendProfile& p, double x0, double mu, double length, double g = 9.81) {
  const double dx = 1e-3;
  double e = 0, x = x0;  // e = v^2 / 2
  while (x < length) {
    const double slope = (p.ground(x) - p.ground(x + dx)) / dx, cos_t = 1 / std::sqrt(1 + slope * slope);
    e += (g * slope - mu * g - mu * 2 * e * p.curvature(x + 0.5 * dx) / cos_t) * dx;
    x += dx;
    if (e <= 0 && x > x0 + 1) break;
  }
  return x - x0;
}

}  // namespace runout_test
