// Kernel normalisation and gradient consistency, both kernels, 2D and 3D.
#include <gtest/gtest.h>

#include <cmath>

#include "runout/engine/kernels.hpp"

using namespace runout;

namespace {

// Integral of W over the plane/space by radial quadrature: 2D 2 pi r dr, 3D 4 pi r^2 dr.
template <int D, class K>
double radial_integral(const K& k, double (*weight)(const K&, double)) {
  const int n = 200000;
  const double R = k.support();
  double s = 0;
  for (int i = 0; i < n; ++i) {
    const double r = (i + 0.5) * R / n;
    const double shell = D == 2 ? 2 * kPi * r : 4 * kPi * r * r;
    s += weight(k, r) * shell * R / n;
  }
  return s;
}

template <class K>
double w_of(const K& k, double r) {
  return k.W(r);
}
// -∫ r·∇W dV = D for a normalised kernel (integration by parts); grad W = F(r) r, so r·∇W = F r^2.
template <class K>
double r_dot_grad(const K& k, double r) {
  return -k.grad_factor(r) * r * r;
}

template <int D, class K>
void check_kernel(double h) {
  K k(h);
  EXPECT_NEAR((radial_integral<D, K>(k, &w_of<K>)), 1.0, 1e-6) << K::name << " D=" << D;
  EXPECT_NEAR((radial_integral<D, K>(k, &r_dot_grad<K>)), static_cast<double>(D), 1e-6) << K::name << " D=" << D;
  // The analytic gradient matches a finite difference of W everywhere inside the support.
  for (double q = 0.05; q < 2.0; q += 0.05) {
    const double r = q * h, e = 1e-7 * h;
    const double fd = (k.W(r + e) - k.W(r - e)) / (2 * e);
    EXPECT_NEAR(k.grad_factor(r) * r, fd, 1e-6 * std::abs(k.W(0)) / h) << K::name << " q=" << q;
  }
  EXPECT_NEAR(k.W(2.0 * h), 0.0, 1e-12 * k.W(0));  // zero at the support edge (to rounding)
  EXPECT_NEAR(k.grad_factor(2.0 * h), 0.0, 1e-12 * k.W(0) / (h * h));
  EXPECT_EQ(k.W(2.01 * h), 0.0);
}

}  // namespace

TEST(Kernels, WendlandNormalisedAndConsistent2D) { check_kernel<2, WendlandC2<2>>(0.013); }
TEST(Kernels, WendlandNormalisedAndConsistent3D) { check_kernel<3, WendlandC2<3>>(0.013); }
TEST(Kernels, CubicSplineNormalisedAndConsistent2D) { check_kernel<2, CubicSpline<2>>(0.02); }
TEST(Kernels, CubicSplineNormalisedAndConsistent3D) { check_kernel<3, CubicSpline<3>>(0.02); }

// On a regular lattice with h = 1.5 dp the discrete sums reproduce the continuous identities closely:
// sum V_j W_ij ≈ 1 and sum V_j (x_j - x_i) ⊗ ∇_i W_ij ≈ I (the gradient of a linear field is exact).
TEST(Kernels, LatticeSumsReproduceConstantAndLinearFields) {
  const double dp = 0.01, h = 1.5 * dp;
  for (int which = 0; which < 2; ++which) {
    double sumW = 0, gxx = 0, gxy = 0;
    auto add = [&](auto k) {
      for (int a = -5; a <= 5; ++a)
        for (int b = -5; b <= 5; ++b) {
          const double x = a * dp, y = b * dp, r = std::hypot(x, y);
          sumW += dp * dp * k.W(r);
          // ∇_i W_ij with r_ij = x_i - x_j = -(x, y): F * (-(x, y)); (x_j - x_i) = (x, y)
          const double F = k.grad_factor(r);
          gxx += dp * dp * x * (F * -x);
          gxy += dp * dp * x * (F * -y);
        }
    };
    if (which == 0) add(WendlandC2<2>(h)); else add(CubicSpline<2>(h));
    EXPECT_NEAR(sumW, 1.0, 0.01);
    EXPECT_NEAR(gxx, 1.0, 0.01);  // d(x)/dx = 1 from sum V_j (x_j - x_i) (∇_i W_ij)_x
    EXPECT_NEAR(gxy, 0.0, 1e-12);
  }
}

TEST(Kernels, NamesRoundTripAndUnknownIsRefused) {
  EXPECT_EQ(kernel_from_name("wendland"), KernelKind::wendland);
  EXPECT_EQ(kernel_from_name("cubic"), KernelKind::cubic);
  EXPECT_THROW(kernel_from_name("gaussian"), std::invalid_argument);
}
