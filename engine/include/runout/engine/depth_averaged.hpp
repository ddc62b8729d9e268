#pragma once
// Thickness-integrated (depth-averaged) SPH: the screening model (docs/design.md, "Thickness-integrated SPH
// (screening rung)"). Particles move in plan (x, y) over a bed surface z_b(x, y); each carries a fixed volume
// and a velocity tangent to the bed; the flow thickness is the SPH sum of the volumes in plan, the momentum
// balance is gravity along the bed, the depth-integrated pressure gradient -k g cos(theta) grad h and a basal
// resistance law (one file each under src/depth_averaged/friction/, registered by one line). The formulation
// follows McDougall & Hungr (2004, DAN3D) and AvaFrame's com1DFA (docs.avaframe.org, "theoryCom1DFA");
// the code is written from the equations, not from either.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "runout/engine/kernels.hpp"
#include "runout/engine/parameters.hpp"
#include "runout/engine/types.hpp"

namespace runout::depth_averaged {

using Vec2 = Eigen::Matrix<real, 2, 1>;
using Vec3 = Eigen::Matrix<real, 3, 1>;
using Mat2 = Eigen::Matrix<real, 2, 2>;

// The bed at a plan point: elevation, gradient (dz/dx, dz/dy) and Hessian (curvature load on the bed).
struct BedSample {
  real z = 0;
  Vec2 grad = Vec2::Zero();
  Mat2 hess = Mat2::Zero();
  // cos of the slope angle: the bed normal's vertical component, 1 / sqrt(1 + |grad z|^2).
  real cos_slope() const;
  // The upward unit normal (-z_x, -z_y, 1) cos(theta).
  Vec3 normal() const;
};

// The bed surface z_b(x, y). Sampled once per particle per step (a std::function call, never per pair).
class Bed {
 public:
  // z = z0 + sx x + sy y (an inclined plane; exact gradient, no curvature).
  static Bed plane(real z0, real sx, real sy);
  // Any callable; gradient and Hessian by central differences of step `fd_step` [m].
  static Bed function(std::function<real(real, real)> z, real fd_step);
  // A regular grid (a DEM): nx * ny node values, row-major from (x0, y0) (index ix + nx iy), spacing dx, dy.
  // Elevation bilinear between nodes; the gradient and Hessian bilinear between their nodal central
  // differences (one-sided at the edges), so the slope is continuous across cells. Outside the grid the edge
  // value's plane is extended. Throws std::invalid_argument for fewer than 2 x 2 nodes or a size mismatch.
  // curvature_scale > 0 takes the Hessian (the bend's centripetal load) from the grid smoothed by a Gaussian of
  // that standard deviation [m]: the curvature the flow feels at its own scale, not the DEM's metre-scale
  // roughness, which the load's floor at zero normal stress would turn into friction on average.
  static Bed grid(real x0, real y0, real dx, real dy, int nx, int ny, std::vector<real> z, real curvature_scale = 0);

  BedSample sample(real x, real y) const { return f_(x, y); }

 private:
  explicit Bed(std::function<BedSample(real, real)> f) : f_(std::move(f)) {}
  std::function<BedSample(real, real)> f_;
};

// A basal resistance law: the bed shear stress over density, tau_b / rho [m^2/s^2], for a batch of particles
// (one virtual call per step). It is applied against the motion, and never reverses it within a step.
class BasalFriction {
 public:
  virtual ~BasalFriction() = default;
  // normal_stress: sigma_n / rho = h g_n [m^2/s^2]; speed |u| [m/s]; thickness h [m].
  virtual void shear_stress(std::span<const real> normal_stress, std::span<const real> speed,
                            std::span<const real> thickness, std::span<real> tau) const = 0;
};

// A law as a user names it (like a RheologyModel): name, one line of doc, parameters, factory.
struct FrictionModel {
  std::string name;
  std::string doc;
  std::vector<ParameterSpec> parameters;
  std::unique_ptr<BasalFriction> (*create)(const ParameterValues&, real gravity);
};

// Registered laws (src/depth_averaged/friction/registry.hpp), in registration order.
const std::vector<const FrictionModel*>& friction_models();
// Throws std::invalid_argument naming the accepted names.
const FrictionModel& friction_model(const std::string& name);
// Resolves `given` against the law's parameters (defaults, ranges) and builds it; throws std::invalid_argument
// "<path>.<key>: ..." for a value out of range.
std::unique_ptr<BasalFriction> make_friction(const std::string& name, const ParameterValues& given, real gravity,
                                             const std::string& path = "friction");

struct Config {
  real gravity = 9.81;                     // [m/s^2]
  real earth_pressure = 1.0;               // k: pressure term -k g_n grad h (1: hydrostatic, isotropic)
  // Savage & Hutter's (1989) earth-pressure coefficients in place of k: along the flow k_x from the internal
  // friction angle phi and the bed's delta, active where the flow stretches (du_s/ds >= 0), passive where it
  // is compressed; across it k_y from k_x and the sign of the lateral strain (savage_hutter_coefficients).
  bool savage_hutter = false;
  real internal_friction_angle = 30;      // phi [deg]
  real bed_friction_angle = 20;           // delta [deg], 0 <= delta <= phi
  real spacing = 1.0;                      // initial plan spacing of the particles [m]
  real smoothing_ratio = 1.5;              // kernel smoothing length / spacing (support 2 h_k)
  // Adaptive smoothing length: h_k,i = smoothing_ratio sqrt(V_i / rho_i) (rho_i the volume per plan area),
  // between the initial h_k0 = smoothing_ratio spacing and max_smoothing_growth h_k0, so a thinning flow keeps
  // its neighbours; false: h_k0 for every particle.
  bool adaptive_smoothing = true;
  real max_smoothing_growth = 4.0;
  KernelKind kernel = KernelKind::wendland;
  real cfl = 0.2;                          // dt <= cfl h_k / max(sqrt(k g_n h) + |u|)
  real dt_max = 0.1;                       // [s]
  bool curvature = true;                   // add the centripetal load u^T H u cos(theta) to the normal stress
  std::string friction = "coulomb";
  ParameterValues friction_parameters;
  // Periodic plan axes (x, y) over [domain_min, domain_max): for test sheets and strips on a plane (a period
  // shorter than a kernel's support sums every image).
  std::array<bool, 2> periodic{false, false};
  Vec2 domain_min = Vec2::Zero(), domain_max = Vec2::Zero();
};

// Savage & Hutter's (1989) coefficients for phi and delta [deg] (as AvaFrame's ana1Tests/simiSolTest.py
// defineEarthPressCoeff writes them): k_x = 2 / cos^2 phi (1 -+ sqrt(1 - cos^2 phi / cos^2 delta)) - 1 (active,
// passive), k_y = (k_x + 1 -+ sqrt((1 - k_x)^2 + 4 tan^2 delta)) / 2 (active, passive) for each k_x. Throws
// std::invalid_argument unless 0 <= delta <= phi < 90.
struct EarthPressureCoefficients {
  real kx[2];     // [0] active, [1] passive
  real ky[2][2];  // [k_x passive][k_y passive]
};
EarthPressureCoefficients savage_hutter_coefficients(real phi_deg, real delta_deg);

// The model's own numbers, declared once (as every engine model declares its parameters) for the scene step.
const std::vector<ParameterSpec>& config_parameters();

// Particle data, structure of arrays. The model reorders particles by cell every step; `id` follows them.
struct Particles {
  std::vector<real> x, y;          // plan position [m]
  std::vector<real> volume;        // fixed [m^3]
  std::vector<real> ux, uy, uz;    // depth-averaged velocity, tangent to the bed [m/s]
  std::vector<real> h;             // flow thickness normal to the bed, from the last step [m]
  std::vector<real> smoothing;     // the particle's kernel smoothing length h_k,i [m]
  std::vector<uint32_t> id;
  size_t size() const { return x.size(); }
  // Appends a particle at rest (velocity set to zero; thickness filled by the model).
  void add(real px, real py, real vol);
};

class Model {
 public:
  // Throws std::invalid_argument for a bad friction name or parameter, a non-positive spacing or smoothing
  // settings out of range.
  Model(const Config& config, Bed bed, Particles particles);
  ~Model();
  Model(Model&&) noexcept;

  // One kick-drift-kick leapfrog step with the CFL step; returns dt. Throws SimulationError on a non-finite value.
  real step();
  // Steps until time() reaches t exactly (the last step is shortened).
  void advance_to(real t);
  // Appends particles with their positions, volumes and velocities (a hydrograph's inflow); ids continue from
  // size(), thickness and smoothing are filled here, the next step moves them with the rest.
  void add_particles(const Particles& more);
  real time() const { return time_; }
  size_t steps() const { return steps_; }
  const Particles& particles() const { return p_; }
  const Config& config() const { return config_; }
  const Bed& bed() const { return bed_; }
  // The initial (smallest) kernel smoothing length h_k0 = smoothing_ratio spacing.
  real smoothing_length() const { return h_kernel_; }
  // Sum of the particles' volumes (constant: particles carry fixed volume).
  real total_volume() const;
  // The SPH thickness at any plan point, each particle spreading its volume with its own kernel:
  // cos(theta) sum_j V_j W(|x - x_j|, h_k,j) (its plan integral is the total volume).
  real thickness_at(real x, real y) const;

 private:
  struct Impl;
  real step_to(real t_limit);
  void refresh();
  real accelerations();
  Vec2 savage_hutter_gradient(size_t i, real& k_max) const;
  void kick(real dt);
  void drift(real dt);
  void check_finite() const;
  Config config_;
  Bed bed_;
  Particles p_;
  real h_kernel_ = 0;
  real h_kernel_max_ = 0;  // the largest h_k,i now (thickness_at's search)
  real time_ = 0;
  size_t steps_ = 0;
  // The accelerations (Impl::ax, ay, az) are those of the particles as they stand, and the step they allow.
  bool accelerations_current_ = false;
  real next_dt_ = 0;
  std::unique_ptr<BasalFriction> friction_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace runout::depth_averaged
