// The bed surface of the thickness-integrated model: a plane, a callable or a regular grid (a DEM).
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "runout/engine/depth_averaged.hpp"

namespace runout::depth_averaged {

real BedSample::cos_slope() const { return 1.0 / std::sqrt(1.0 + grad.squaredNorm()); }

Vec3 BedSample::normal() const { return Vec3(-grad.x(), -grad.y(), 1.0) * cos_slope(); }

Bed Bed::plane(real z0, real sx, real sy) {
  return Bed([=](real x, real y) {
    BedSample s;
    s.z = z0 + sx * x + sy * y;
    s.grad = Vec2(sx, sy);
    return s;
  });
}

Bed Bed::function(std::function<real(real, real)> z, real fd_step) {
  if (!(fd_step > 0)) throw std::invalid_argument("Bed::function: fd_step must be positive");
  return Bed([z = std::move(z), e = fd_step](real x, real y) {
    BedSample s;
    s.z = z(x, y);
    const real xp = z(x + e, y), xm = z(x - e, y), yp = z(x, y + e), ym = z(x, y - e);
    s.grad = Vec2(xp - xm, yp - ym) / (2 * e);
    const real xy = (z(x + e, y + e) - z(x + e, y - e) - z(x - e, y + e) + z(x - e, y - e)) / (4 * e * e);
    s.hess << (xp - 2 * s.z + xm) / (e * e), xy, xy, (yp - 2 * s.z + ym) / (e * e);
    return s;
  });
}

namespace {

// Nodal elevation, gradient and Hessian of a grid, so a sample is four bilinear blends.
struct GridBed {
  real x0, y0, dx, dy;
  int nx, ny;
  std::vector<real> z, zx, zy, zxx, zxy, zyy;

  real at(const std::vector<real>& f, int i, int j) const { return f[static_cast<size_t>(i) + nx * static_cast<size_t>(j)]; }

  // A separable Gaussian of standard deviation sigma [m] over the nodes (truncated at 3 sigma, renormalised at
  // the edges).
  std::vector<real> smoothed(const std::vector<real>& f, real sigma) const {
    std::vector<real> tmp(f.size()), out(f.size());
    auto pass = [&](const std::vector<real>& in, std::vector<real>& res, int axis) {
      const real h = axis == 0 ? dx : dy;
      const int r = std::max(1, static_cast<int>(std::ceil(3 * sigma / h))), m = axis == 0 ? nx : ny;
      for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i) {
          const int k = axis == 0 ? i : j;
          real sum = 0, w = 0;
          for (int o = std::max(0, k - r); o <= std::min(m - 1, k + r); ++o) {
            const real wo = std::exp(-0.5 * std::pow((o - k) * h / sigma, 2));
            sum += wo * (axis == 0 ? at(in, o, j) : at(in, i, o)), w += wo;
          }
          res[i + nx * static_cast<size_t>(j)] = sum / w;
        }
    };
    pass(f, tmp, 0);
    pass(tmp, out, 1);
    return out;
  }

  // Differences between nodes i-1 and i+1 (one-sided at the edges): exact for planes and quadratics inside. The
  // Hessian from the grid smoothed at curvature_scale when it is positive.
  void differentiate(real curvature_scale) {
    const size_t n = z.size();
    zx.assign(n, 0), zy.assign(n, 0), zxx.assign(n, 0), zxy.assign(n, 0), zyy.assign(n, 0);
    auto d = [&](const std::vector<real>& f, int i, int j, int axis) {
      const int m = axis == 0 ? nx : ny;
      const int k = axis == 0 ? i : j;
      const int a = std::max(k - 1, 0), b = std::min(k + 1, m - 1);
      const real fa = axis == 0 ? at(f, a, j) : at(f, i, a), fb = axis == 0 ? at(f, b, j) : at(f, i, b);
      return (fb - fa) / ((b - a) * (axis == 0 ? dx : dy));
    };
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        zx[i + nx * static_cast<size_t>(j)] = d(z, i, j, 0);
        zy[i + nx * static_cast<size_t>(j)] = d(z, i, j, 1);
      }
    std::vector<real> sx = zx, sy = zy;
    if (curvature_scale > 0) {
      const std::vector<real> zs = smoothed(z, curvature_scale);
      for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i) {
          sx[i + nx * static_cast<size_t>(j)] = d(zs, i, j, 0);
          sy[i + nx * static_cast<size_t>(j)] = d(zs, i, j, 1);
        }
    }
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        const size_t k = i + nx * static_cast<size_t>(j);
        zxx[k] = d(sx, i, j, 0);
        zyy[k] = d(sy, i, j, 1);
        zxy[k] = 0.5 * (d(sx, i, j, 1) + d(sy, i, j, 0));
      }
  }

  BedSample sample(real x, real y) const {
    // Clamped to the grid: outside, the edge node's plane continues (elevation from its gradient).
    const real u = std::clamp((x - x0) / dx, 0.0, nx - 1.0), v = std::clamp((y - y0) / dy, 0.0, ny - 1.0);
    const int i = std::min(static_cast<int>(u), nx - 2), j = std::min(static_cast<int>(v), ny - 2);
    const real fu = u - i, fv = v - j;
    auto blend = [&](const std::vector<real>& f) {
      return (1 - fu) * (1 - fv) * at(f, i, j) + fu * (1 - fv) * at(f, i + 1, j) + (1 - fu) * fv * at(f, i, j + 1) +
             fu * fv * at(f, i + 1, j + 1);
    };
    BedSample s;
    s.grad = Vec2(blend(zx), blend(zy));
    const real xc = x0 + u * dx, yc = y0 + v * dy;
    s.z = blend(z) + s.grad.x() * (x - xc) + s.grad.y() * (y - yc);
    s.hess << blend(zxx), blend(zxy), blend(zxy), blend(zyy);
    return s;
  }
};

}  // namespace

Bed Bed::grid(real x0, real y0, real dx, real dy, int nx, int ny, std::vector<real> z, real curvature_scale) {
  if (nx < 2 || ny < 2) throw std::invalid_argument("Bed::grid: needs at least 2 x 2 nodes");
  if (z.size() != static_cast<size_t>(nx) * static_cast<size_t>(ny))
    throw std::invalid_argument("Bed::grid: " + std::to_string(z.size()) + " values for " + std::to_string(nx) +
                                " x " + std::to_string(ny) + " nodes");
  if (!(dx > 0 && dy > 0)) throw std::invalid_argument("Bed::grid: spacing must be positive");
  auto g = std::make_shared<GridBed>(GridBed{x0, y0, dx, dy, nx, ny, std::move(z), {}, {}, {}, {}, {}});
  g->differentiate(curvature_scale);
  return Bed([g](real x, real y) { return g->sample(x, y); });
}

}  // namespace runout::depth_averaged
