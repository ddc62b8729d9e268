#include "runout/scenarios/study.hpp"

#include "runout/scenarios/ensemble_summary.hpp"
#include "runout/scenarios/thread_share.hpp"

#include <omp.h>

#include <algorithm>
#include <fstream>
#include <mutex>
#include <sstream>
#include <thread>

#include <nlohmann/json.hpp>

namespace runout {

namespace fs = std::filesystem;
using json = nlohmann::json;

std::map<std::string, std::string> read_series(const fs::path& run_dir) {
  std::map<std::string, std::string> out;
  const fs::path dir = run_dir / "series";
  if (!fs::is_directory(dir)) return out;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (!e.is_regular_file() || e.path().extension() != ".csv") continue;
    std::ifstream in(e.path(), std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    out[e.path().stem().string()] = s.str();
  }
  return out;
}

std::optional<StoredRun> find_completed_run(const RunStore& store, const std::string& manifest_hash) {
  const auto id = store.find_run(manifest_hash);
  if (!id) return std::nullopt;
  const auto row = store.get_run(*id);
  if (!row || row->status != "completed") return std::nullopt;
  StoredRun out;
  out.run_id = *id;
  out.status = row->status;
  out.reused = true;
  return out;
}

RunStore::RunRecord run_record(const Manifest& manifest, const std::string& scene, const std::string& fidelity,
                               const RunSummary& summary, const fs::path& out_dir) {
  RunStore::RunRecord r;
  r.manifest_hash = manifest.hash;
  r.manifest_json = manifest.json;
  r.scene = scene;
  r.fidelity = fidelity;
  r.status = summary.status;
  r.metrics_json = summary.metrics_json;
  r.series_csv = read_series(out_dir);
  return r;
}

RunStore::RunRecord execute_run(const std::string& resolved_json, const Manifest& manifest, const fs::path& base_dir,
                                const StoreRunOptions& options, StoredRun& result) {
  return execute_run(parse_scene_document(resolved_json), manifest, base_dir, options, result);
}

RunStore::RunRecord execute_run(const json& resolved, const Manifest& manifest, const fs::path& base_dir,
                                const StoreRunOptions& options, StoredRun& result) {
  const Scene scene = build_scene(read_scene(resolved, base_dir));
  // A stale or half-written directory from an interrupted run goes, unless it holds a checkpoint to resume.
  if (!(options.run.checkpoint_interval > 0 && has_checkpoint_of(scene, options.run.out_dir)))
    fs::remove_all(options.run.out_dir);
  const RunSummary s = run_scene(scene, options.run);
  result.status = s.status;
  result.error = s.error;
  result.wall_seconds = s.wall_seconds;
  RunStore::RunRecord r =
      run_record(manifest, scene.name, options.fidelity.dp ? "custom" : options.fidelity.name, s, options.run.out_dir);
  r.sweep = options.sweep;
  r.variant = options.variant;
  return r;
}

StoredRun run_and_store(RunStore& store, const std::string& resolved_json, const fs::path& base_dir,
                        const StoreRunOptions& options) {
  return run_and_store(store, parse_scene_document(resolved_json), base_dir, options);
}

StoredRun run_and_store(RunStore& store, const json& resolved, const fs::path& base_dir,
                        const StoreRunOptions& options) {
  const Manifest manifest = make_manifest(resolved, base_dir, options.fidelity);
  if (auto stored = find_completed_run(store, manifest.hash)) return *stored;
  StoredRun out;
  const RunStore::RunRecord r = execute_run(resolved, manifest, base_dir, options, out);
  out.run_id = store.put_run(r);
  return out;
}

SweepResult run_sweep(RunStore& store, const Sweep& sweep, const SweepOptions& options) {
  const Fidelity fidelity = options.fidelity_override ? options.fidelity : sweep.fidelity;
  const size_t n = sweep.variants.size();
  SweepResult result;
  result.runs.resize(n);
  for (const auto& v : sweep.variants) result.variants.push_back(v.name);
  for (auto& r : result.runs) r.status = "not run";

  const int jobs = std::clamp(options.jobs, 1, static_cast<int>(std::max<size_t>(n, 1)));
  ThreadShare share(omp_get_num_procs());  // without --threads, the layouts going at once divide the cores
  const fs::path base_dir = sweep.base_path.parent_path();
  std::mutex event_mutex;
  auto emit = [&](const SweepEvent& e) {
    if (!options.on_event) return;
    std::lock_guard lock(event_mutex);
    options.on_event(e);
  };
  std::atomic<size_t> next{0};
  auto worker = [&] {
    for (;;) {
      if (options.stop && options.stop->load()) return;
      const size_t k = next.fetch_add(1);
      if (k >= n) return;
      const SweepVariant& v = sweep.variants[k];
      SweepEvent e{SweepEvent::started, v.name, k, n, {}, {}};
      emit(e);
      StoreRunOptions o;
      o.sweep = sweep.name;
      o.variant = v.name;
      o.fidelity = fidelity;
      o.run.out_dir = options.out_root / sweep.name / v.name;
      ThreadShare::Lease lease(share);
      o.run.threads = options.threads;
      if (options.threads <= 0) o.run.threads_now = lease.threads_now();
      o.run.stop = options.stop;
      o.run.checkpoint_interval = options.checkpoint_interval;
      o.run.on_progress = [&, k](const RunProgress& p) {
        SweepEvent pe{SweepEvent::progress, sweep.variants[k].name, k, n, p, {}};
        emit(pe);
      };
      StoredRun r;
      try {
        r = run_and_store(store, resolve_variant(sweep.base_json, v, fidelity), base_dir, o);
      } catch (const std::exception& ex) {
        r.status = "failed";
        r.error = ex.what();
      }
      result.runs[k] = r;
      SweepEvent fe{SweepEvent::finished, v.name, k, n, {}, r};
      emit(fe);
    }
  };
  std::vector<std::thread> pool;
  for (int j = 1; j < jobs; ++j) pool.emplace_back(worker);
  worker();
  for (auto& t : pool) t.join();
  if (!(options.stop && options.stop->load())) {
    result.differences = write_sweep_differences(options.out_root / sweep.name, sweep);
    result.exceedance = write_ensemble_outputs(store, options.out_root / sweep.name, sweep);
  }
  return result;
}

}  // namespace runout
