#include "runout/engine/rheology.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace runout {
namespace {

// (1 - exp(-m g)) / g, exact as g -> 0 (limit m) thanks to expm1.
inline real papanastasiou_factor(real m, real g) { return -std::expm1(-m * g) / g; }

// mu g^(n-1): pow is skipped when n == 1 (the common case) for speed and exactness.
inline real power_law(real mu, real n, real g) { return n == 1.0 ? mu : mu * std::pow(g, n - 1.0); }

void require(bool ok, const MaterialParams& p, const char* field, const char* range) {
  if (ok) return;
  std::ostringstream s;
  s << "materials." << p.name << "." << field << ": must be " << range;
  throw std::invalid_argument(s.str());
}

void check_common(const MaterialParams& p) {
  require(std::isfinite(p.density) && p.density > 0, p, "density", "> 0 kg/m^3");
  require(std::isfinite(p.viscosity) && p.viscosity >= 0 && p.viscosity <= 1e8, p, "viscosity",
          "in [0, 1e8] Pa s^n");
}

void check_hbp(const MaterialParams& p) {
  require(std::isfinite(p.flow_index) && p.flow_index > 0 && p.flow_index <= 5, p, "flow_index", "in (0, 5]");
  require(std::isfinite(p.regularisation) && p.regularisation > 0 && p.regularisation <= 1e8, p,
          "regularisation", "in (0, 1e8] s");
}

}  // namespace

void Newtonian::effective_viscosity(std::span<const real>, std::span<const real>, std::span<real> mu_eff) const {
  for (auto& v : mu_eff) v = mu_;
}

void Bingham::effective_viscosity(std::span<const real> gamma_dot, std::span<const real>,
                                  std::span<real> mu_eff) const {
  for (size_t k = 0; k < mu_eff.size(); ++k) mu_eff[k] = mu_ + tau_y_ / gamma_dot[k];
}

void HerschelBulkleyPapanastasiou::effective_viscosity(std::span<const real> gamma_dot, std::span<const real>,
                                                       std::span<real> mu_eff) const {
  for (size_t k = 0; k < mu_eff.size(); ++k) {
    const real g = gamma_dot[k];
    mu_eff[k] = power_law(mu_, n_, g) + tau_y_ * papanastasiou_factor(m_, g);
  }
}

FrictionHBP::FrictionHBP(real consistency, real flow_index, real regularisation, real friction_angle_deg,
                         real cohesion)
    : mu_(consistency),
      n_(flow_index),
      m_(regularisation),
      sin_phi_(std::sin(friction_angle_deg * kPi / 180.0)),
      cos_phi_(std::cos(friction_angle_deg * kPi / 180.0)),
      cohesion_(cohesion) {}

void FrictionHBP::effective_viscosity(std::span<const real> gamma_dot, std::span<const real> pressure,
                                      std::span<real> mu_eff) const {
  for (size_t k = 0; k < mu_eff.size(); ++k) {
    const real g = gamma_dot[k];
    const real p = pressure[k] > 0 ? pressure[k] : 0.0;
    const real tau_y = p * sin_phi_ + cohesion_ * cos_phi_;
    mu_eff[k] = power_law(mu_, n_, g) + tau_y * papanastasiou_factor(m_, g);
  }
}

const std::map<std::string, RheologyFactory>& rheology_registry() {
  static const std::map<std::string, RheologyFactory> registry = {
      {"newtonian",
       [](const MaterialParams& p) {
         check_common(p);
         return std::make_unique<Newtonian>(p.viscosity);
       }},
      {"bingham",
       [](const MaterialParams& p) {
         check_common(p);
         require(std::isfinite(p.yield_stress) && p.yield_stress >= 0 && p.yield_stress <= 1e7, p,
                 "yield_stress", "in [0, 1e7] Pa");
         return std::make_unique<Bingham>(p.viscosity, p.yield_stress);
       }},
      {"hbp",
       [](const MaterialParams& p) {
         check_common(p);
         check_hbp(p);
         require(std::isfinite(p.yield_stress) && p.yield_stress >= 0 && p.yield_stress <= 1e7, p,
                 "yield_stress", "in [0, 1e7] Pa");
         return std::make_unique<HerschelBulkleyPapanastasiou>(p.viscosity, p.flow_index, p.regularisation,
                                                               p.yield_stress);
       }},
      {"friction-hbp",
       [](const MaterialParams& p) {
         check_common(p);
         check_hbp(p);
         require(std::isfinite(p.friction_angle_deg) && p.friction_angle_deg >= 0 && p.friction_angle_deg < 90,
                 p, "friction_angle", "in [0, 90) degrees");
         require(std::isfinite(p.cohesion) && p.cohesion >= 0 && p.cohesion <= 1e7, p, "cohesion",
                 "in [0, 1e7] Pa");
         return std::make_unique<FrictionHBP>(p.viscosity, p.flow_index, p.regularisation, p.friction_angle_deg,
                                              p.cohesion);
       }},
  };
  return registry;
}

std::vector<std::string> rheology_names() {
  std::vector<std::string> names;
  for (const auto& [name, factory] : rheology_registry()) names.push_back(name);
  return names;
}

std::unique_ptr<Rheology> make_rheology(const MaterialParams& params) {
  const auto& reg = rheology_registry();
  auto it = reg.find(params.rheology);
  if (it == reg.end()) {
    std::string accepted;
    for (const auto& n : rheology_names()) accepted += (accepted.empty() ? "" : ", ") + n;
    throw std::invalid_argument("materials." + params.name + ".rheology: unknown '" + params.rheology +
                                "' (accepted: " + accepted + ")");
  }
  return it->second(params);
}

}  // namespace runout
