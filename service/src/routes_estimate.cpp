// Routes: POST /estimate: a job resolved and costed, nothing written (server_impl.hpp, docs/service.md).
#include "server_impl.hpp"

namespace runout::service {

void Server::Impl::routes_estimate() {
  // The estimate of a job before it is submitted: the body of POST /jobs, resolved and built the same way
  // (so the particle counts are the job's), and the run time from the calibrated cost model
  // (runout/scenarios/cost_model.hpp, docs/tradeoff.md). Writes nothing.
  add("/estimate", "POST", [this](const httplib::Request& req, httplib::Response& res, const std::smatch&) {
    only_params(req, {});
    check_json_body(req);
    (void)header_key(req);  // checked as for POST /jobs, then unused
    std::optional<std::string> bkey;
    const JobSpec spec = parse_job_request(req.body, limits, *queue, bkey);
    const CostModel model = CostModel::calibrated();
    const int threads = std::max(1, threads_per_job);
    const CostPrediction p = model.predict(spec.cost, threads);
    const CostCoefficients& k = model.coefficients(spec.cost);
    send_json(res, 200,
              {{"scene_name", spec.scene_name},
               {"variant", spec.variant},
               {"fidelity", spec.fidelity},
               {"dp", spec.resolved_dp},
               {"dimensions", spec.dimensions},
               {"particles",
                {{"fluid", spec.fluid_particles},
                 {"boundary", spec.boundary_particles},
                 {"total", spec.particles},
                 {"fluid_peak_estimate", p.fluid_peak},
                 {"boundary_peak_estimate", p.boundary_peak}}},
               {"particle_budget", opt.particle_budget},
               {"steps_estimate", static_cast<int64_t>(p.steps)},
               {"seconds_estimate", p.seconds},
               {"model",
                {{"formula", "steps = ceil(step_ratio * duration / dt0); seconds = steps * (a_fluid * fluid_mean * "
                             "neighbours * passes + b_fluid * fluid_mean + b_boundary * boundary_peak + c_step) / speedup; boundary_peak = boundary_fixed "
                             "+ min(bed, bed_per_flow_column * fluid_peak^((D-1)/D)); speedup = 1 + "
                             "parallel_efficiency * fluid_mean / (fluid_mean + parallel_half_fluid) * (threads - 1)"},
                 {"flow_model", spec.cost.model},
                 {"duration_s", spec.cost.duration},
                 {"dt_s", spec.cost.dt0},
                 {"fluid_mean", spec.cost.fluid_mean},
                 {"neighbours", spec.cost.neighbours},
                 {"passes", spec.cost.passes},
                 {"boundary", spec.cost.boundary},
                 {"boundary_fixed", spec.cost.boundary_fixed},
                 {"bed", spec.cost.bed},
                 {"fluid_peak", spec.cost.fluid_peak},
                 {"bed_per_flow_column", model.bed_per_flow_column},
                 {"step_ratio", k.step_ratio},
                 {"a_fluid_s", k.a_fluid},
                 {"b_fluid_s", k.b_fluid},
                 {"b_boundary_s", k.b_boundary},
                 {"c_step_s", k.c_step},
                 {"threads", threads},
                 {"parallel_efficiency", model.parallel_efficiency},
                 {"parallel_half_fluid", model.parallel_half_fluid},
                 {"speedup", p.speedup},
                 {"seconds_per_step", p.seconds_per_step},
                 {"note", "calibrated on measured runs of the shipped scenes; how well it predicts: docs/tradeoff.md"}}}});
  });
}

}  // namespace runout::service
