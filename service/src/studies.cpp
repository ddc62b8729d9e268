// Multi-fidelity studies as sweeps (docs/service.md, "Studies"): the screening stage is an ensemble sweep's jobs
// (stage 1); once none of them is queued or running, the layouts that can still be best are chosen from the
// members done (scenarios/multi_fidelity.hpp, as `runout study` chooses them) and their detailed jobs (stage 2,
// planned and checked at submission) are queued in the same transaction that records the outcome.
#include "server_impl.hpp"

#include "runout/scenarios/ensemble_summary.hpp"
#include "runout/scenarios/multi_fidelity.hpp"

namespace runout::service {

namespace {

json spec_json(const JobSpec& s) {
  return {{"scene_name", s.scene_name}, {"scene_json", s.scene_json}, {"scene_id", s.scene_id ? json(*s.scene_id) : json(nullptr)},
          {"fidelity", s.fidelity},     {"dp", s.dp ? json(*s.dp) : json(nullptr)},  {"sweep", s.sweep},
          {"variant", s.variant},       {"particles", s.particles},                   {"duration", s.duration},
          {"cpu_seconds", s.cpu_seconds}, {"submitted_by", s.submitted_by}};
}

JobSpec spec_of(const json& j) {
  JobSpec s;
  s.scene_name = j.at("scene_name").get<std::string>();
  s.scene_json = j.at("scene_json").get<std::string>();
  if (!j.at("scene_id").is_null()) s.scene_id = j.at("scene_id").get<int64_t>();
  s.fidelity = j.at("fidelity").get<std::string>();
  if (!j.at("dp").is_null()) s.dp = j.at("dp").get<double>();
  s.sweep = j.at("sweep").get<std::string>();
  s.variant = j.at("variant").get<std::string>();
  s.particles = j.at("particles").get<int64_t>();
  s.duration = j.at("duration").get<double>();
  s.cpu_seconds = j.at("cpu_seconds").get<double>();
  s.submitted_by = j.at("submitted_by").get<std::string>();
  s.stage = 2;
  return s;
}

// The ensemble sweep the plan describes, as `runout study` reads it from a sweep file: its layouts and ensemble.
Sweep study_sweep(const json& plan, const std::string& name) {
  Sweep s;
  s.name = name;
  s.base_json = plan.at("base").get<std::string>();
  for (const auto& l : plan.at("layouts")) {
    const auto name = l.at("name").get<std::string>();
    s.variants.push_back({name, l.at("structures").get<std::vector<std::string>>(), {}, name, -1});
  }
  s.ensemble = parse_ensemble(plan.at("ensemble").get<std::string>(), s.base_json);
  return s;
}

// Jobs per status, their count and the mean progress (a finished job counts 1), of one stage's jobs.
json stage_json(const std::vector<Job>& jobs, int stage, const std::string& fidelity) {
  json by_status = {{"queued", 0}, {"running", 0}, {"done", 0}, {"failed", 0}, {"cancelled", 0}};
  int64_t total = 0;
  double fraction = 0;
  for (const auto& j : jobs) {
    if (j.stage != stage) continue;
    by_status[j.status] = by_status[j.status].get<int64_t>() + 1;
    ++total;
    fraction += sweep_share(j);
  }
  return {{"fidelity", fidelity},
          {"jobs_total", total},
          {"jobs_by_status", by_status},
          {"progress", {{"fraction", total > 0 ? fraction / static_cast<double>(total) : 0.0}}}};
}

}  // namespace

std::string study_plan_json(const NewSweep& s) {
  json layouts = json::array(), median = json::array(), candidates = json::array();
  for (const auto& v : s.variants) layouts.push_back({{"name", v.name}, {"structures", v.structures}});
  for (const auto& p : s.study->median) median.push_back({{"pointer", p.pointer}, {"value", p.value}});
  for (const auto& c : s.study->candidates) candidates.push_back(spec_json(c));
  const Fidelity& f = s.study->fidelity;
  return json{{"fidelity", f.dp ? "custom" : f.name},
              {"dp", f.dp ? json(*f.dp) : json(nullptr)},
              {"screening_fidelity", s.fidelity},
              {"base", s.base_json},
              {"layouts", layouts},
              {"ensemble", *s.ensemble_json},
              {"median_member", median},
              {"candidates", candidates}}
      .dump();
}

// Decides every study whose screening stage has ended. Called by the workers between jobs, so a study whose
// last screening job ended before a restart, or was cancelled, is decided as well.
bool Server::Impl::decide_studies() {
  std::lock_guard lock(studies_mutex);
  bool decided = false;
  for (const int64_t id : queue->studies_to_decide()) {
    try {
      decided = decide_study(id) || decided;
    } catch (const std::exception& e) {
      spdlog::error("sweep {}: the study's screening stage could not be decided: {}", id, e.what());
    }
  }
  return decided;
}

bool Server::Impl::decide_study(int64_t id) {
  const auto row = queue->get_sweep(id);
  const auto record = queue->study(id);
  if (!row || !record) return false;
  const json plan = json::parse(record->plan);
  const Sweep sweep = study_sweep(plan, row->name);
  std::map<std::string, int64_t> runs;  // the screening members done
  int64_t cancelled = 0;
  for (const auto& j : queue->list(std::nullopt, id, 100000, 0)) {
    if (j.stage == 1 && j.status == "done" && j.run_id && split_member_name(j.variant)) runs[j.variant] = *j.run_id;
    if (j.stage == 1 && j.status == "cancelled") ++cancelled;
  }
  RunStore store(opt.db);  // this thread's own connection
  const auto summary = summarise_ensemble_runs(store, row->name, runs);
  MultiFidelityResult r;
  std::vector<JobSpec> chosen;
  if (summary) {
    r = screening_outcome(sweep, *summary);
    for (const auto& c : plan.at("candidates"))
      if (std::count(r.selection.chosen.begin(), r.selection.chosen.end(), c.at("variant").get<std::string>()))
        chosen.push_back(spec_of(c));
  }
  json outcome = json::parse(multi_fidelity_json(r));
  outcome.erase("stopped");
  if (cancelled > 0) {  // cancelling a study's jobs stops it: nothing the client did not expect runs after
    chosen.clear();
    outcome["note"] = std::to_string(cancelled) + " screening job(s) cancelled: no detailed job queued (submit the "
                      "study again to run it; its stored runs are reused)";
  }
  outcome.erase("ranking");  // of the detailed stage: added when it is read (study_of)
  if (!queue->decide_study(id, outcome.dump(), chosen)) return false;
  spdlog::info("sweep {}: screening decided over {} member(s); {} layout(s) go on to {}", id,
               summary ? summary->members : 0, chosen.size(), plan.at("fidelity").get<std::string>());
  wake.notify_all();
  return true;
}

// GET /sweeps/{id}'s `study`: each stage's progress, and once the screening stage is decided its outcome (as
// `runout study` writes study.json), each chosen layout's detailed value of the ranking metric filled in from
// its done job and the detailed ranking.
json Server::Impl::study_of(const SweepRow& row, const std::vector<Job>& jobs) const {
  const auto record = queue->study(row.id);
  if (!record) return nullptr;
  const json plan = json::parse(record->plan);
  json out = {{"stage", "screening"},
              {"screening", stage_json(jobs, 1, plan.at("screening_fidelity").get<std::string>())},
              {"detailed", stage_json(jobs, 2, plan.at("fidelity").get<std::string>())},
              {"median_member", plan.at("median_member")},
              {"outcome", nullptr}};
  out["detailed"]["candidates"] = plan.at("candidates").size();
  if (!record->outcome) return out;
  json outcome = json::parse(*record->outcome);
  MultiFidelityResult r;
  r.ranking_metric = outcome.value("ranking_metric", std::string());
  std::map<std::string, std::optional<double>> values;
  for (const auto& j : jobs) {
    if (j.stage != 2) continue;
    r.detailed_sweep.variants.push_back({j.variant, {}, {}, j.variant, -1});
    if (j.status != "done" || !j.run_id || r.ranking_metric.empty()) continue;
    const auto m = store->metrics(*j.run_id);
    if (const auto it = m.find(r.ranking_metric); it != m.end()) values[j.variant] = it->second;
  }
  set_detailed_values(r, values);
  for (auto& l : outcome["layouts"]) {
    const auto layout = l.value("layout", std::string());
    if (l.value("chosen", false)) l["detailed"] = values.count(layout) ? json(*values.at(layout)) : json(nullptr);
  }
  outcome["ranking"] = r.detailed_ranking;
  out["outcome"] = outcome;
  const bool detailed_active = std::any_of(jobs.begin(), jobs.end(), [](const Job& j) {
    return j.stage == 2 && (j.status == "queued" || j.status == "running");
  });
  out["stage"] = detailed_active ? "detailed" : "done";
  return out;
}

}  // namespace runout::service
