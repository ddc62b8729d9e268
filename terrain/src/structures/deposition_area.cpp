// Deposition area: the bed inside becomes a plane through its centroid, at `elevation` (default: the mean
// ground inside), falling at `gradient` along the ground's mean downhill direction. No wall; it holds the
// flow that lies inside at the end.
#include <cmath>

#include "structure_steps.hpp"

namespace runout::terrain::detail {
namespace {

// The downhill direction is the one a plane fit of the ground inside gives.
void edit_bed(Grid& bed, const std::vector<int>& owner, int k, const StructureSpec& s, double cell, StructureInfo& info) {
  const int nx = bed.nx, ny = bed.ny;
  std::vector<size_t> cols;
  double sx = 0, sy = 0, sz = 0;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i)
      if (owner[column(bed, i, j)] == k) {
        cols.push_back(column(bed, i, j));
        sx += bed.cx(i), sy += bed.cy(j), sz += bed.at(i, j);
      }
  const double n = static_cast<double>(cols.size());
  const double mx = sx / n, my = sy / n, mz = sz / n;
  double sxx = 0, sxy = 0, syy = 0, sxz = 0, syz = 0;
  for (size_t c : cols) {
    const double x = bed.cx(static_cast<int>(c % nx)) - mx, y = bed.cy(static_cast<int>(c / nx)) - my,
                 z = bed.values[c] - mz;
    sxx += x * x, sxy += x * y, syy += y * y, sxz += x * z, syz += y * z;
  }
  const double det = sxx * syy - sxy * sxy;
  double gx = 0, gy = 0;  // ground gradient dz/dx, dz/dy
  if (std::abs(det) > 1e-12) {
    gx = (sxz * syy - syz * sxy) / det;
    gy = (syz * sxx - sxz * sxy) / det;
  }
  const double gnorm = std::hypot(gx, gy);
  const double ux = gnorm > 0 ? -gx / gnorm : 0.0, uy = gnorm > 0 ? -gy / gnorm : 0.0;  // downhill
  const double e0 = s.has("elevation") ? s.number("elevation") : mz;
  const double gradient = s.number("gradient");
  for (size_t c : cols) {
    const double x = bed.cx(static_cast<int>(c % nx)) - mx, y = bed.cy(static_cast<int>(c / nx)) - my;
    const double znew = e0 - gradient * (ux * x + uy * y);
    const double dz = znew - bed.values[c];
    (dz > 0 ? info.fill_volume : info.cut_volume) += std::abs(dz) * cell;
    bed.values[c] = static_cast<float>(znew);
  }
}

bool holds(const StructureInfo& st, double x, double y, double, bool) { return inside_polygon(st.outline, x, y); }

std::optional<StructureProblem> check(const StructureSpec&) { return std::nullopt; }

void footprint(const StructureSpec&, const Grid&, double, Footprint&) {}  // no wall

const StructureSteps steps{footprint, edit_bed, nullptr, nullptr};

}  // namespace

const StructureType& deposition_area_type() {
  static const StructureType type{
      "deposition_area",
      "the bed inside becomes a plane through the centroid falling along the ground's mean downhill direction",
      {geometry_field("polygon", true, "the area: at least 3 [x, y] points (map coordinates, m)"),
       number_field({"elevation", "m", 0.0, -500.0, 9000.0, false, false, false, "the plane's elevation at the centroid"},
                    0, "the mean ground elevation inside"),
       number_field({"gradient", "m/m", 0.0, 0.0, 1.0, false, false, false, "the plane's downhill slope"})},
      true,
      "deposition area",
      "#8c6d31",
      check,
      holds,
      false,
      &steps};
  return type;
}

}  // namespace runout::terrain::detail
