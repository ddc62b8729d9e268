// The wall's normal at each fixed wall particle, estimated from how its wall neighbours are arranged: a wall
// is a sheet a few particles thick, so its particles spread least across it. The normal is the principal axis
// of least second moment of the neighbours' offsets within `radius` (about the particle, weighted by
// (1 - r^2/radius^2)^2, periodic images included). Its sign is left arbitrary: the extrapolated pressure's hydrostatic term, (g.n)(n.dx), is even in
// n. A particle with fewer than D neighbours gets a zero normal (the term then uses all of g).
#include <Eigen/Eigenvalues>

#include <cmath>
#include <unordered_map>

#include "wall_normals.hpp"

namespace runout {
namespace solver_detail {

namespace {

template <int D>
uint64_t cell_key(const std::array<int64_t, D>& c) {
  uint64_t k = 0;
  for (int d = 0; d < D; ++d) k = k * 2097169u + static_cast<uint64_t>(c[d] + (int64_t{1} << 40));
  return k;
}

}  // namespace

template <int D>
std::vector<Vec<D>> estimate_wall_normals(const std::array<std::vector<real>, D>& pos, real radius,
                                          const Vec<D>& period) {
  const size_t n = pos[0].size();
  auto at = [&](size_t b) {
    Vec<D> x;
    for (int d = 0; d < D; ++d) x[d] = pos[d][b];
    return x;
  };
  auto cell_of = [&](const Vec<D>& x) {
    std::array<int64_t, D> c;
    for (int d = 0; d < D; ++d) c[d] = static_cast<int64_t>(std::floor(x[d] / radius));
    return c;
  };
  std::unordered_map<uint64_t, std::vector<uint32_t>> cells;
  for (size_t b = 0; b < n; ++b) cells[cell_key<D>(cell_of(at(b)))].push_back(static_cast<uint32_t>(b));

  // Periodic images: offsets of -1, 0, +1 period along each periodic axis.
  std::vector<Vec<D>> images(1, Vec<D>::Zero());
  for (int d = 0; d < D; ++d) {
    if (!(period[d] > 0)) continue;
    const size_t m = images.size();
    for (size_t k = 0; k < m; ++k)
      for (real s : {-1.0, 1.0}) {
        Vec<D> v = images[k];
        v[d] += s * period[d];
        images.push_back(v);
      }
  }

  std::vector<Vec<D>> normals(n, Vec<D>::Zero());
  const real r2max = radius * radius;
#pragma omp parallel for schedule(dynamic, 256)
  for (size_t b = 0; b < n; ++b) {
    const Vec<D> xb = at(b);
    Mat<D> moment = Mat<D>::Zero();
    int count = 0;
    for (const Vec<D>& shift : images) {
      const Vec<D> x = xb + shift;  // b seen from the image, so neighbours near the seam are found
      const auto c0 = cell_of(x);
      const int nc = D == 2 ? 9 : 27;
      for (int o = 0; o < nc; ++o) {
        std::array<int64_t, D> c = c0;
        for (int d = 0, r = o; d < D; ++d, r /= 3) c[d] += r % 3 - 1;
        const auto it = cells.find(cell_key<D>(c));
        if (it == cells.end()) continue;
        for (uint32_t j : it->second) {
          if (j == b && shift.isZero()) continue;
          const Vec<D> r = at(j) - x;
          const real q = r.squaredNorm() / r2max;
          if (q >= 1) continue;
          // A weight falling smoothly to 0 at the radius, so a lattice neighbour that rounding puts just inside
          // or just outside it (at exactly the radius) does not tilt the axis.
          moment.noalias() += ((1 - q) * (1 - q)) * r * r.transpose();
          ++count;
        }
      }
    }
    if (count < D) continue;
    const Eigen::SelfAdjointEigenSolver<Mat<D>> eig(moment);
    normals[b] = eig.eigenvectors().col(0).normalized();  // eigenvalues ascend: the axis of least spread
  }
  return normals;
}

template std::vector<Vec<2>> estimate_wall_normals<2>(const std::array<std::vector<real>, 2>&, real, const Vec<2>&);
template std::vector<Vec<3>> estimate_wall_normals<3>(const std::array<std::vector<real>, 3>&, real, const Vec<3>&);

}  // namespace solver_detail
}  // namespace runout
