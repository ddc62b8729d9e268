#pragma once
// Smoothing kernels (thesis eq. 2.6-2.7). Both have support radius 2h.
// A kernel is a small value type with W(r) and grad_factor(r) such that grad_i W_ij = grad_factor(r) * r_ij
// (and grad_factor_in_support(r, 1/r), the same inside the support given 1/r).
// The solver is templated on the kernel type, so the hot loop has no virtual call; a new kernel is a new
// struct here (with its `name` and `alias`) plus one line in RUNOUT_KERNELS.
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "runout/engine/types.hpp"

namespace runout {

template <int D>
struct WendlandC2 {
  static constexpr std::string_view name = "wendland", alias = "wendland-c2";
  real h, inv_h, alpha;
  explicit WendlandC2(real smoothing_length) : h(smoothing_length), inv_h(1.0 / smoothing_length) {
    alpha = (D == 2) ? 7.0 / (4.0 * kPi * h * h) : 21.0 / (16.0 * kPi * h * h * h);
  }
  real support() const { return 2.0 * h; }
  real W(real r) const {
    const real q = r * inv_h;
    if (q >= 2.0) return 0.0;
    const real t = 1.0 - 0.5 * q;
    const real t2 = t * t;
    return alpha * t2 * t2 * (2.0 * q + 1.0);
  }
  // dW/dr / r: W = a (1-q/2)^4 (2q+1); dW/dq = -5 a q (1-q/2)^3
  real grad_factor(real r) const {
    const real q = r * inv_h;
    if (q >= 2.0) return 0.0;
    const real t = 1.0 - 0.5 * q;
    return -5.0 * alpha * t * t * t * inv_h * inv_h;
  }
  // The same for 0 < r < 2h (a pair list's entries), with 1/r supplied: no branches, so pair loops vectorise.
  real grad_factor_in_support(real r, real /*inv_r*/) const {
    const real t = 1.0 - 0.5 * r * inv_h;
    return -5.0 * alpha * t * t * t * inv_h * inv_h;
  }
};

template <int D>
struct CubicSpline {
  static constexpr std::string_view name = "cubic", alias = "cubic-spline";
  real h, inv_h, alpha;
  explicit CubicSpline(real smoothing_length) : h(smoothing_length), inv_h(1.0 / smoothing_length) {
    alpha = (D == 2) ? 10.0 / (7.0 * kPi * h * h) : 1.0 / (kPi * h * h * h);
  }
  real support() const { return 2.0 * h; }
  // Both branches are evaluated and one selected: whether a neighbour is inside q = 1 is as good as random,
  // and a mispredicted branch costs more than the few flops.
  real W(real r) const {
    const real q = r * inv_h;
    if (q >= 2.0) return 0.0;
    const real t = 2.0 - q;
    const real inner = alpha * (1.0 - 1.5 * q * q + 0.75 * q * q * q);
    const real outer = alpha * 0.25 * t * t * t;
    return q < 1.0 ? inner : outer;
  }
  real grad_factor(real r) const {
    const real q = r * inv_h;
    if (q >= 2.0 || r <= 0.0) return 0.0;
    const real t = 2.0 - q;
    const real inner = alpha * (-3.0 * q + 2.25 * q * q);
    const real outer = -0.75 * alpha * t * t;
    return (q < 1.0 ? inner : outer) * inv_h / r;
  }
  // The same for 0 < r < 2h (a pair list's entries), with 1/r supplied (the pair loops share one division
  // among several terms): no branches, so pair loops vectorise. Inside q = 1, dW/dq / r = alpha (-3 + 2.25 q) / h^2
  // needs no 1/r.
  real grad_factor_in_support(real r, real inv_r) const {
    const real q = r * inv_h;
    const real t = 2.0 - q;
    const real inner = alpha * (-3.0 + 2.25 * q) * inv_h * inv_h;
    const real outer = -0.75 * alpha * t * t * inv_h * inv_r;
    return q < 1.0 ? inner : outer;
  }
};

// The kernel list: one line per kernel (its struct above). The enum, the dispatch and the names below are
// generated from it, so a kernel cannot be parsed without being dispatched, or named differently.
#define RUNOUT_KERNELS(X) \
  X(wendland, WendlandC2) \
  X(cubic, CubicSpline)

enum class KernelKind {
#define RUNOUT_KERNEL_ENUM(id, type) id,
  RUNOUT_KERNELS(RUNOUT_KERNEL_ENUM)
#undef RUNOUT_KERNEL_ENUM
};

// Parses a kernel name or its alias; throws std::invalid_argument naming the accepted values.
KernelKind kernel_from_name(std::string_view name);
std::string_view kernel_name(KernelKind kind);
std::vector<std::string> kernel_names();

// Calls f(kernel) with the concrete kernel type for `kind`: one switch per call, not per pair.
template <int D, class F>
decltype(auto) with_kernel(KernelKind kind, real smoothing_length, F&& f) {
  switch (kind) {
#define RUNOUT_KERNEL_CASE(id, type) \
  case KernelKind::id:               \
    return f(type<D>(smoothing_length));
    RUNOUT_KERNELS(RUNOUT_KERNEL_CASE)
#undef RUNOUT_KERNEL_CASE
  }
  throw std::invalid_argument("with_kernel: not a registered kernel");
}

}  // namespace runout
