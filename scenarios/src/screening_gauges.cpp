// The screening run's section gauges and check-dam loads (screening_gauges.hpp).
#include "screening_gauges.hpp"

#include <cmath>
#include <fstream>
#include <iomanip>

#include "runout/engine/geometry.hpp"
#include "runout/engine/kernels.hpp"
#include "run_outputs.hpp"
#include "screening_run.hpp"

namespace runout {
namespace {

using json = nlohmann::json;
namespace da = depth_averaged;

// A file name from a monitor's or structure's name: characters outside [A-Za-z0-9._-] become '_'.
std::string file_safe(std::string name) {
  for (char& c : name)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '.' && c != '-' && c != '_') c = '_';
  return name;
}

// The flow at a plan point, gathered from the particles: volume per plan area sum V W, and sum V W u (plan).
struct FlowAt {
  double depth = 0, qx = 0, qy = 0;
};

FlowAt flow_at(const da::Model& m, double x, double y) {
  const da::Particles& p = m.particles();
  FlowAt f;
  for (size_t k = 0; k < p.size(); ++k) {
    const double dx = x - p.x[k], dy = y - p.y[k], hk = p.smoothing[k];
    if (dx * dx + dy * dy >= 4 * hk * hk) continue;
    const double w = p.volume[k] * with_kernel<2>(m.config().kernel, hk, [&](const auto& kernel) {
      return kernel.W(std::sqrt(dx * dx + dy * dy));
    });
    f.depth += w, f.qx += w * p.ux[k], f.qy += w * p.uy[k];
  }
  return f;
}

}  // namespace

ScreeningGauges::ScreeningGauges(const Scene& scene, const ScreeningSettings& s, const da::Model& model)
    : tm_(*scene.terrain), density_(s.density), gravity_(model.config().gravity), window_(s.output_interval) {
  const da::Particles& p = model.particles();
  for (const auto& spec : scene.monitors) {
    if (spec.type != "section") {
      skipped_.push_back(spec.type + " '" + spec.name + "'");
      continue;
    }
    auto sec = std::make_unique<Section>();
    sec->name = spec.name;
    for (const auto& q : spec.points) sec->line.push_back({q[0], q[1]});
    // Downstream as the 3D gauge takes it: the side most of the flow is not on, when most of it lies within
    // the line's ends; otherwise the side opposite the flow's centroid.
    long pos = 0, neg = 0;
    double cx = 0, cy = 0;
    for (size_t k = 0; k < p.size(); ++k) {
      const int r = raw_side(*sec, p.x[k], p.y[k]);
      pos += r > 0, neg += r < 0, cx += p.x[k] / p.size(), cy += p.y[k] / p.size();
    }
    if (p.size() == 0 && tm_.inflow_line.size() == 2) {  // a hydrograph's flow starts at its line
      cx = 0.5 * (tm_.inflow_line[0][0] + tm_.inflow_line[1][0]) - tm_.origin_x;
      cy = 0.5 * (tm_.inflow_line[0][1] + tm_.inflow_line[1][1]) - tm_.origin_y;
    }
    if (2 * (pos + neg) > static_cast<long>(p.size()) && pos != neg) {
      sec->downstream = pos > neg ? -1 : 1;
    } else {
      SegmentRules rules;
      rules.skip_zero_length = true;
      sec->downstream = nearest_segment(sec->line, cx, cy, rules).side < 0 ? 1 : -1;
    }
    sec->side.assign(p.size(), 0);
    for (size_t k = 0; k < p.size(); ++k) sec->side[p.id[k]] = static_cast<int8_t>(raw_side(*sec, p.x[k], p.y[k]) * sec->downstream);
    sec->arrival_volume = spec.number("arrival_volume") > 0 ? spec.number("arrival_volume") : 0.005 * model.total_volume();
    sec->csv << std::setprecision(9) << "t,discharge_m3_s,volume_passed_m3\n0,0,0\n";
    sections_.push_back(std::move(sec));
  }
  // Check dams: points along the axis every dp, moved upstream by half the wall's thickness and 1.5 spacings, where
  // the flow in front of the wall is sampled (the raised bed's own slope stays out of cos theta there).
  for (size_t k = 0; k < tm_.structures.size(); ++k) {
    const auto& st = tm_.structures[k];
    if (st.type->area) continue;  // a wall along an axis is loaded along it
    auto d = std::make_unique<DamLoad>();
    d->structure = k;
    d->normal = st.flow_normal;
    d->offset = 0.5 * std::max(st.wall_thickness, tm_.dp) + 1.5 * std::max(s.spacing, tm_.dp);
    d->ds = tm_.dp;
    for (size_t e = 0; e + 1 < st.outline.size(); ++e) {
      const auto& a = st.outline[e];
      const auto& b = st.outline[e + 1];
      const double len = std::hypot(b[0] - a[0], b[1] - a[1]);
      for (double t = 0.5 * d->ds; t < len; t += d->ds) {
        const double x = a[0] + (b[0] - a[0]) * t / len - d->offset * d->normal[0] - tm_.origin_x;
        const double y = a[1] + (b[1] - a[1]) * t / len - d->offset * d->normal[1] - tm_.origin_y;
        if (!std::isnan(tm_.bed_at(x, y))) d->points.push_back({x, y});
      }
    }
    d->csv << std::setprecision(9) << "t,force_n,peak_line_load_n_m\n";
    dams_.push_back(std::move(d));
  }
}

int ScreeningGauges::raw_side(const Section& s, double x, double y) const {
  SegmentRules rules;
  rules.ends = SegmentRules::Ends::skip;
  rules.skip_zero_length = true;
  const NearestSegment n = nearest_segment(s.line, x, y, rules);
  return n.index < 0 ? 0 : n.side;
}

void ScreeningGauges::sample(const da::Model& m) {
  const da::Particles& p = m.particles();
  for (auto& s : sections_) {
    if (s->side.size() < p.size()) s->side.resize(p.size(), 0);  // a hydrograph's new particles
    double dv = 0;
    for (size_t k = 0; k < p.size(); ++k) {
      const int now = raw_side(*s, p.x[k], p.y[k]) * s->downstream;
      if (now == 0) continue;
      int8_t& before = s->side[p.id[k]];
      if (before == -1 && now == 1) dv += p.volume[k];
      if (before == 1 && now == -1) dv -= p.volume[k];
      before = static_cast<int8_t>(now);
    }
    s->passed += dv;
    if (s->arrival < 0 && s->passed > 0 && s->passed >= s->arrival_volume) s->arrival = m.time();
    const double q = m.time() > s->last_t ? dv / (m.time() - s->last_t) : 0.0;
    if (q > s->peak) s->peak = q, s->peak_t = m.time();
    s->last_t = m.time();
    s->csv << m.time() << ',' << q << ',' << s->passed << '\n';
  }
  for (auto& d : dams_) sample_dam(*d, m);
}

// The load per unit crest length rho (g h^2 cos(theta) / 2 + h u_n^2): the depth-integrated hydrostatic thrust of
// the layer of thickness h (normal to the bed) and the momentum flux of the flow moving at u_n (>= 0) towards
// the wall, integrated along the crest.
void ScreeningGauges::sample_dam(DamLoad& d, const da::Model& m) {
  double force = 0, line_peak = 0;
  for (const auto& q : d.points) {
    const FlowAt f = flow_at(m, q[0], q[1]);
    if (f.depth <= 0) continue;
    const double cos_t = ground_cos(q[0], q[1], m), h = f.depth * cos_t;
    const double un = std::max(0.0, (f.qx * d.normal[0] + f.qy * d.normal[1]) / f.depth);
    const double load = density_ * (0.5 * gravity_ * h * h * cos_t + h * un * un);
    force += load * d.ds;
    line_peak = std::max(line_peak, load);
  }
  if (force > d.peak) d.peak = force, d.peak_t = m.time();
  d.peak_line = std::max(d.peak_line, line_peak);
  d.csv << m.time() << ',' << force << ',' << line_peak << '\n';
}

// cos(theta) of the ground before structures (the raised wall's ramp in the bed grid would tilt it near the
// wall), by central differences over dp; the model's bed where the ground has no value.
double ScreeningGauges::ground_cos(double x, double y, const da::Model& m) const {
  const double e = tm_.dp, X = x + tm_.origin_x, Y = y + tm_.origin_y;
  const double gx = (tm_.original.sample(X + e, Y) - tm_.original.sample(X - e, Y)) / (2 * e);
  const double gy = (tm_.original.sample(X, Y + e) - tm_.original.sample(X, Y - e)) / (2 * e);
  if (!std::isfinite(gx) || !std::isfinite(gy)) return m.bed().sample(x, y).cos_slope();
  return 1 / std::sqrt(1 + gx * gx + gy * gy);
}

void ScreeningGauges::write(const std::filesystem::path& dir) const {
  for (const auto& s : sections_) run_outputs::write_file_atomically(dir / ("section_" + file_safe(s->name) + ".csv"), s->csv.str());
  for (const auto& d : dams_)
    run_outputs::write_file_atomically(dir / ("screening_load_" + file_safe(tm_.structures[d->structure].name) + ".csv"),
                                       d->csv.str());
}

json ScreeningGauges::sections() const {
  json out = json::array();
  for (const auto& s : sections_)
    out.push_back({{"name", s->name},
                   {"type", "section"},
                   {"peak_discharge_m3_s", s->peak},
                   {"time_of_peak_s", s->peak_t},
                   {"arrival_time_s", s->arrival},
                   {"volume_passed_m3", s->passed},
                   {"discharge_window_s", window_}});
  return out;
}

json ScreeningGauges::dam_load(size_t structure) const {
  for (const auto& d : dams_)
    if (d->structure == structure)
      return {{"peak_force_n", d->peak},
              {"time_of_peak_force_s", d->peak_t},
              {"peak_line_load_n_m", d->peak_line},
              {"sampled_upstream_m", d->offset},
              {"stations", d->points.size()},
              {"rule", "rho (g h^2 cos(theta) / 2 + h u_n^2) along the crest, the flow sampled at sampled_upstream_m "
                       "in front of the axis every dp, every screening.output_interval"}};
  return nullptr;
}

}  // namespace runout
