// Sweeps over MPI ranks (mpi_sweep.hpp, docs/cluster.md).
#include "mpi_sweep.hpp"

#include <mpi.h>
#include <sched.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <deque>
#include <list>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "runout/scenarios/ensemble_summary.hpp"
#include "runout/scenarios/sweep.hpp"
#include "sweep_cost.hpp"

namespace runout::cluster {

namespace {

using json = nlohmann::json;
using Clock = std::chrono::steady_clock;
namespace fs = std::filesystem;

// Message tags. Rank 0 -> worker: a run to do, stop the current run, exit, "still here". Worker -> rank 0:
// heartbeat (with the run's progress), the finished run's record.
enum Tag : int { kTask = 1, kStopRun = 2, kShutdown = 3, kPing = 4, kHeartbeat = 10, kResult = 11 };

std::string dump(const json& j) { return j.dump(-1, ' ', false, json::error_handler_t::replace); }

double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// A message that has arrived (Iprobe), received whole; nullopt when none is waiting.
struct Message {
  int source = 0, tag = 0;
  std::string text;
};
std::optional<Message> try_receive(int source, int tag) {
  int flag = 0;
  MPI_Status st;
  if (MPI_Iprobe(source, tag, MPI_COMM_WORLD, &flag, &st) != MPI_SUCCESS || !flag) return std::nullopt;
  int count = 0;
  MPI_Get_count(&st, MPI_CHAR, &count);
  Message m;
  m.source = st.MPI_SOURCE;
  m.tag = st.MPI_TAG;
  m.text.resize(static_cast<size_t>(std::max(count, 0)));
  MPI_Recv(m.text.data(), count, MPI_CHAR, m.source, m.tag, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
  return m;
}

// Nonblocking sends whose buffers live until they complete. A send to a rank that died never completes; it
// is left pending (rank 0 then ends without MPI_Finalize, MpiWorld::finish).
class Outbox {
 public:
  // synchronous: complete only once the receiver has taken it (MPI_Issend). A small standard send completes
  // as soon as it is buffered, and a sender that then leaves without MPI_Finalize can take it along unsent.
  void send(int dest, int tag, std::string text, bool synchronous = false) {
    auto& s = pending_.emplace_back();
    s.text = std::move(text);
    s.dest = dest;
    if (synchronous)
      MPI_Issend(s.text.data(), static_cast<int>(s.text.size()), MPI_CHAR, dest, tag, MPI_COMM_WORLD, &s.request);
    else
      MPI_Isend(s.text.data(), static_cast<int>(s.text.size()), MPI_CHAR, dest, tag, MPI_COMM_WORLD, &s.request);
  }
  void progress() {
    for (auto it = pending_.begin(); it != pending_.end();) {
      int done = 0;
      MPI_Test(&it->request, &done, MPI_STATUS_IGNORE);
      it = done ? pending_.erase(it) : std::next(it);
    }
  }
  // Waits until every send to a rank in `alive` has completed, or the deadline passes.
  bool drain(const std::vector<bool>& alive, double timeout_s) {
    const auto t0 = Clock::now();
    for (;;) {
      progress();
      const bool left = std::any_of(pending_.begin(), pending_.end(), [&](const Pending& p) {
        return p.dest < static_cast<int>(alive.size()) && alive[static_cast<size_t>(p.dest)];
      });
      if (!left) return true;
      if (seconds_since(t0) > timeout_s) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  }

 private:
  struct Pending {
    std::string text;
    int dest = 0;
    MPI_Request request = MPI_REQUEST_NULL;
  };
  std::list<Pending> pending_;  // a list: Isend holds pointers into the strings
};

json record_to_json(const RunStore::RunRecord& r) {
  return {{"manifest_hash", r.manifest_hash}, {"sweep", r.sweep},       {"variant", r.variant},
          {"scene", r.scene},                 {"fidelity", r.fidelity}, {"status", r.status},
          {"metrics_json", r.metrics_json},   {"manifest_json", r.manifest_json}, {"series_csv", r.series_csv}};
}

RunStore::RunRecord record_from_json(const json& j) {
  RunStore::RunRecord r;
  r.manifest_hash = j.at("manifest_hash").get<std::string>();
  r.sweep = j.at("sweep").get<std::string>();
  r.variant = j.at("variant").get<std::string>();
  r.scene = j.at("scene").get<std::string>();
  r.fidelity = j.at("fidelity").get<std::string>();
  r.status = j.at("status").get<std::string>();
  r.metrics_json = j.at("metrics_json").get<std::string>();
  r.manifest_json = j.at("manifest_json").get<std::string>();
  r.series_csv = j.at("series_csv").get<std::map<std::string, std::string>>();
  return r;
}

int count_cpus_in_mask() {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof set, &set) != 0) return 0;
  return CPU_COUNT(&set);
}

}  // namespace

// ---------------------------------------------------------------------------------------------------------

MpiWorld::MpiWorld() {
  int provided = 0;
  MPI_Init_thread(nullptr, nullptr, MPI_THREAD_SERIALIZED, &provided);
  if (provided < MPI_THREAD_SERIALIZED)
    spdlog::warn("MPI provides thread level {} (< MPI_THREAD_SERIALIZED); heartbeats may be unsafe", provided);
  // A lost rank must not abort rank 0 from inside an MPI call: errors come back as codes.
  MPI_Comm_set_errhandler(MPI_COMM_WORLD, MPI_ERRORS_RETURN);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);

  // Ranks computing on this node: all of them, less rank 0 when it only coordinates.
  MPI_Comm node;
  MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, 0, MPI_INFO_NULL, &node);
  int local = 1, has_root = 0, is_root = rank_ == 0 ? 1 : 0;
  MPI_Comm_size(node, &local);
  MPI_Allreduce(&is_root, &has_root, 1, MPI_INT, MPI_SUM, node);
  MPI_Comm_free(&node);
  const int computing = std::max(1, local - (size_ > 1 ? has_root : 0));
  const int online = static_cast<int>(std::max(1L, sysconf(_SC_NPROCESSORS_ONLN)));
  const int mask = count_cpus_in_mask();
  if (std::getenv("OMP_NUM_THREADS"))
    default_threads_ = 0;
  else if (mask > 0 && mask < online)
    default_threads_ = mask;  // bound by the launcher: its CPU set is this rank's share
  else
    default_threads_ = std::max(1, online / computing);
}

MpiWorld::~MpiWorld() {
  if (!finished_) {
    finished_ = true;
    MPI_Finalize();
  }
}

int MpiWorld::finish(int code) {
  if (finished_) return code;
  finished_ = true;
  if (peer_lost_) {
    if (rank_ == 0)
      spdlog::warn("a worker rank was lost: ending without MPI_Finalize (it would wait for that rank)");
    else
      spdlog::info("rank {}: a rank was lost: ending without MPI_Finalize (it would wait for that rank)", rank_);
    spdlog::default_logger()->flush();
    std::fflush(stdout);
    std::fflush(stderr);
    std::_Exit(code);
  }
  MPI_Finalize();
  return code;
}

void release_workers(MpiWorld& world) {
  Outbox out;
  for (int w = 1; w < world.size(); ++w) out.send(w, kShutdown, "{}", /*synchronous=*/true);
  out.drain(std::vector<bool>(static_cast<size_t>(world.size()), true), 30);
}

// ---------------------------------------------------------------------------------------------------------
// Worker

int run_worker(MpiWorld& world, const MpiSweepOptions& options, const std::atomic<bool>* stop) {
  const int threads = options.threads > 0 ? options.threads : world.default_threads();
  std::mutex mpi;  // MPI_THREAD_SERIALIZED: one MPI call at a time in this process
  std::atomic<bool> run_stop{false}, quit{false};
  std::mutex state_mutex;
  json state = {{"index", -1}};  // what the heartbeat says: the run in hand and its progress

  // Heartbeats from a thread of their own: rank 0 hears from this rank every second whatever the run does.
  std::thread heartbeat([&] {
    while (!quit.load()) {
      std::string text;
      {
        std::lock_guard lock(state_mutex);
        text = dump(state);
      }
      {
        std::lock_guard lock(mpi);
        // Small: sent eagerly, so MPI_Send returns at once.
        MPI_Send(text.data(), static_cast<int>(text.size()), MPI_CHAR, 0, kHeartbeat, MPI_COMM_WORLD);
        while (try_receive(0, kStopRun)) run_stop = true;
      }
      if (stop && stop->load()) run_stop = true;
      for (int k = 0; k < 20 && !quit.load(); ++k) std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  });

  int code = 0;
  // Rank 0 may take long before its first message (it builds every layout to check it and predict its cost),
  // so the silence of rank 0 counts only once it has spoken.
  bool heard_root = false;
  auto last_from_root = Clock::now();
  for (;;) {
    std::optional<Message> m;
    {
      std::lock_guard lock(mpi);
      for (int tag : {kShutdown, kTask, kPing})
        if ((m = try_receive(0, tag))) break;
    }
    if (!m) {
      if (heard_root && seconds_since(last_from_root) > options.heartbeat_timeout) {
        spdlog::error("rank {}: no word from rank 0 for {:.0f} s (--heartbeat-timeout): exiting", world.rank(),
                      options.heartbeat_timeout);
        world.set_peer_lost();
        code = 1;
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      continue;
    }
    last_from_root = Clock::now();
    heard_root = true;
    if (m->tag == kShutdown) {
      // A rank is gone (rank 0 lost a worker, or leaves without MPI_Finalize): MPI_Finalize here would wait
      // for it, and mpirun with the job (measured: 900 s, until the test killed it).
      const json said = json::parse(m->text, nullptr, false);
      if (said.is_object() && said.value("peer_lost", false)) world.set_peer_lost();
      break;
    }
    if (m->tag == kPing) continue;

    // A run: execute it here, send its record to rank 0, which stores it.
    const json task = json::parse(m->text);
    const int64_t index = task.at("index").get<int64_t>();
    StoreRunOptions o;
    o.sweep = task.at("sweep").get<std::string>();
    o.variant = task.at("variant").get<std::string>();
    o.fidelity.name = task.at("fidelity").get<std::string>();
    if (!task.at("dp").is_null()) o.fidelity.dp = task.at("dp").get<double>();
    o.run.out_dir = task.at("out_dir").get<std::string>();
    o.run.threads = threads;
    run_stop = false;
    o.run.stop = &run_stop;
    o.run.on_progress = [&](const RunProgress& p) {
      std::lock_guard lock(state_mutex);
      state = {{"index", index}, {"time", p.time}, {"duration", p.duration}, {"steps", p.steps},
               {"wall_seconds", p.wall_seconds}, {"particles", p.particles}};
    };
    {
      std::lock_guard lock(state_mutex);
      state = {{"index", index}};
    }
    Manifest manifest;
    manifest.hash = task.at("manifest_hash").get<std::string>();
    manifest.json = task.at("manifest_json").get<std::string>();
    json result = {{"index", index}, {"rank", world.rank()}};
    try {
      StoredRun r;
      const RunStore::RunRecord record = execute_run(task.at("scene").get<std::string>(), manifest,
                                                     task.at("base_dir").get<std::string>(), o, r);
      result["record"] = record_to_json(record);
      result["status"] = r.status;
      result["error"] = r.error;
      result["wall_seconds"] = r.wall_seconds;
    } catch (const std::exception& e) {
      // As run_sweep: a run that could not start is reported failed and not stored.
      result["record"] = nullptr;
      result["status"] = "failed";
      result["error"] = e.what();
      result["wall_seconds"] = 0.0;
    }
    {
      std::lock_guard lock(state_mutex);
      state = {{"index", -1}};
    }
    // The record may be megabytes (series): a nonblocking send, so the heartbeat thread keeps its turns.
    const std::string text = dump(result);
    MPI_Request request;
    {
      std::lock_guard lock(mpi);
      MPI_Isend(text.data(), static_cast<int>(text.size()), MPI_CHAR, 0, kResult, MPI_COMM_WORLD, &request);
    }
    const auto t0 = Clock::now();
    bool sent = false;
    while (!sent) {
      {
        std::lock_guard lock(mpi);
        int done = 0;
        MPI_Test(&request, &done, MPI_STATUS_IGNORE);
        sent = done != 0;
      }
      if (!sent && seconds_since(t0) > options.heartbeat_timeout) break;
      if (!sent) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    if (!sent) {
      spdlog::error("rank {}: rank 0 did not take the result of run {} within {:.0f} s: exiting", world.rank(),
                    o.variant, options.heartbeat_timeout);
      world.set_peer_lost();
      code = 1;
      break;
    }
    last_from_root = Clock::now();
  }
  quit = true;
  heartbeat.join();
  return code;
}

// ---------------------------------------------------------------------------------------------------------
// Coordinator (rank 0)

namespace {

// Rank 0's side of a distributed sweep: hands runs out largest predicted cost first, stores each result once,
// gives a silent worker's run to another, and runs what is left itself when no worker remains. One method
// per step of the loop in run().
class Coordinator {
 public:
  Coordinator(MpiWorld& world, RunStore& store, const Sweep& sweep, const SweepOptions& options,
              const MpiSweepOptions& mpi_options)
      : world_(world),
        store_(store),
        sweep_(sweep),
        options_(options),
        mpi_(mpi_options),
        fidelity_(options.fidelity_override ? options.fidelity : sweep.fidelity),
        n_(sweep.variants.size()),
        // The same base folder and output folders as run_sweep: every rank starts in the same working
        // directory (mpirun and srun see to that), so relative paths mean the same on every rank.
        base_dir_(sweep.base_path.parent_path()),
        tasks_(n_),
        finished_(n_, false),
        workers_(static_cast<size_t>(world.size())) {
    result_.runs.resize(n_);
    for (const auto& v : sweep.variants) result_.variants.push_back(v.name);
    for (auto& r : result_.runs) r.status = "not run";
    workers_[0].alive = false;  // rank 0 coordinates
  }

  SweepResult run() {
    prepare();
    while (!pending_.empty() || busy_count() > 0) {
      bool did = false;
      check_stop();
      did = hand_out() || did;
      did = receive() || did;
      did = drop_silent_workers() || did;
      did = run_locally() || did;
      ping_idle();
      out_.progress();
      if (!did) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    shutdown_workers();
    // The workers wrote their rasters under the same output root (a shared file system, as for the store's
    // outputs): the differences against the baseline are rank 0's, as a single-process sweep's are.
    if (!stopping_) {
      result_.differences = write_sweep_differences(options_.out_root / sweep_.name, sweep_);
      result_.exceedance = write_ensemble_outputs(store_, options_.out_root / sweep_.name, sweep_);
    }
    return result_;
  }

 private:
  struct Task {
    std::string scene;
    Manifest manifest;
    double cost = 0;
  };
  struct Worker {
    bool alive = true;
    std::optional<size_t> task;
    Clock::time_point last_heard = Clock::now(), last_ping = Clock::now();
  };

  void emit(const SweepEvent& e) const {
    if (options_.on_event) options_.on_event(e);
  }
  long busy_count() const {
    return std::count_if(workers_.begin(), workers_.end(), [](const Worker& w) { return w.alive && w.task; });
  }
  bool any_alive() const {
    return std::any_of(workers_.begin(), workers_.end(), [](const Worker& w) { return w.alive; });
  }

  // Resolves every layout, takes the stored ones as done (resume), and orders the rest by predicted cost.
  void prepare() {
    std::vector<size_t> todo;
    for (size_t k = 0; k < n_; ++k) {
      const SweepVariant& v = sweep_.variants[k];
      try {
        tasks_[k].scene = resolve_variant(sweep_.base_json, v, fidelity_);
        tasks_[k].manifest = make_manifest(tasks_[k].scene, base_dir_, fidelity_);
        if (auto stored = find_completed_run(store_, tasks_[k].manifest.hash)) {  // resume: not run again
          emit({SweepEvent::started, v.name, k, n_, {}, {}});
          result_.runs[k] = *stored;
          finished_[k] = true;
          emit({SweepEvent::finished, v.name, k, n_, {}, *stored});
          continue;
        }
        tasks_[k].cost = service::predicted_run_cost(tasks_[k].scene, base_dir_);
        todo.push_back(k);
      } catch (const std::exception& e) {  // as run_sweep: reported failed, not stored
        StoredRun r;
        r.status = "failed";
        r.error = e.what();
        result_.runs[k] = r;
        finished_[k] = true;
        emit({SweepEvent::finished, v.name, k, n_, {}, r});
      }
    }
    // Largest predicted cost first, so that the longest run does not start last and hold up the end.
    std::stable_sort(todo.begin(), todo.end(), [&](size_t a, size_t b) { return tasks_[a].cost > tasks_[b].cost; });
    pending_.assign(todo.begin(), todo.end());
    std::string order;
    for (size_t k : todo) order += (order.empty() ? "" : ", ") + sweep_.variants[k].name;
    spdlog::info("sweep {}: {} of {} runs to do on {} worker rank(s), largest predicted cost first: {}", sweep_.name,
                 todo.size(), n_, world_.size() - 1, order.empty() ? "none" : order);
  }

  // Ctrl-C: no new runs; the running ones stop within a step and come back as "stopped".
  void check_stop() {
    if (!options_.stop || !options_.stop->load() || stopping_) return;
    stopping_ = true;
    pending_.clear();
    for (size_t w = 1; w < workers_.size(); ++w)
      if (workers_[w].alive && workers_[w].task) out_.send(static_cast<int>(w), kStopRun, "{}");
  }

  // Hands out runs to idle workers.
  bool hand_out() {
    bool did = false;
    for (size_t w = 1; w < workers_.size() && !pending_.empty() && !stopping_; ++w) {
      if (!workers_[w].alive || workers_[w].task) continue;
      const size_t k = pending_.front();
      pending_.pop_front();
      const SweepVariant& v = sweep_.variants[k];
      const json task = {{"index", k},
                         {"sweep", sweep_.name},
                         {"variant", v.name},
                         {"fidelity", fidelity_.name},
                         {"dp", fidelity_.dp ? json(*fidelity_.dp) : json(nullptr)},
                         {"scene", tasks_[k].scene},
                         {"base_dir", base_dir_.string()},
                         {"out_dir", (options_.out_root / sweep_.name / v.name).string()},
                         {"manifest_hash", tasks_[k].manifest.hash},
                         {"manifest_json", tasks_[k].manifest.json}};
      out_.send(static_cast<int>(w), kTask, dump(task));
      workers_[w].task = k;
      workers_[w].last_heard = Clock::now();  // the clock of its silence starts now
      spdlog::info("{} -> rank {}", v.name, w);
      emit({SweepEvent::started, v.name, k, n_, {}, {}});
      did = true;
    }
    return did;
  }

  // Messages from the workers: heartbeats (progress) and results.
  bool receive() {
    bool did = false;
    while (auto m = try_receive(MPI_ANY_SOURCE, MPI_ANY_TAG)) {
      did = true;
      if (m->source <= 0 || m->source >= world_.size()) continue;
      Worker& w = workers_[static_cast<size_t>(m->source)];
      w.last_heard = Clock::now();
      if (!w.alive && m->tag == kResult) {
        // Declared lost after a silence, yet here it is: it was slow, not dead. Take its result and its work.
        spdlog::warn("rank {} speaks again after being declared lost: it gets runs again", m->source);
        w.alive = true;
      }
      const json msg = json::parse(m->text, nullptr, false);
      if (msg.is_discarded()) {
        spdlog::error("rank {}: unreadable message (tag {})", m->source, m->tag);
        continue;
      }
      if (m->tag == kHeartbeat) on_heartbeat(w, msg);
      else if (m->tag == kResult) on_result(w, m->source, msg);
    }
    return did;
  }

  void on_heartbeat(const Worker& w, const json& msg) const {
    const int64_t k = msg.value("index", int64_t{-1});
    if (!w.alive || !w.task || k != static_cast<int64_t>(*w.task) || !msg.contains("time")) return;
    SweepEvent e{SweepEvent::progress, sweep_.variants[*w.task].name, *w.task, n_, {}, {}};
    e.progress_info.time = msg.value("time", 0.0);
    e.progress_info.duration = msg.value("duration", 0.0);
    e.progress_info.steps = msg.value("steps", 0L);
    e.progress_info.wall_seconds = msg.value("wall_seconds", 0.0);
    e.progress_info.particles = msg.value("particles", size_t{0});
    emit(e);
  }

  void on_result(Worker& w, int source, const json& msg) {
    const size_t k = msg.at("index").get<size_t>();
    if (w.task == k) w.task.reset();
    if (k >= n_) return;
    if (finished_[k]) {
      // Its run was given to another worker after a silence and that one finished it first.
      spdlog::warn("{}: a second result (rank {}) after the run was stored: dropped", sweep_.variants[k].name, source);
      return;
    }
    StoredRun r;
    try {
      r = store_result(k, msg);
    } catch (const std::exception& e) {
      r.status = "failed";
      r.error = std::string("could not store the run: ") + e.what();
    }
    finish_task(k, r);
  }

  StoredRun store_result(size_t k, const json& msg) {
    StoredRun r;
    r.status = msg.at("status").get<std::string>();
    r.error = msg.at("error").get<std::string>();
    r.wall_seconds = msg.at("wall_seconds").get<double>();
    if (!msg.at("record").is_null()) {
      const RunStore::RunRecord record = record_from_json(msg.at("record"));
      if (record.manifest_hash != tasks_[k].manifest.hash)
        throw std::runtime_error("the worker's record of " + sweep_.variants[k].name + " has another manifest hash");
      r.run_id = store_.put_run(record);
    }
    return r;
  }

  void finish_task(size_t k, const StoredRun& r) {
    finished_[k] = true;
    result_.runs[k] = r;
    pending_.erase(std::remove(pending_.begin(), pending_.end(), k), pending_.end());
    emit({SweepEvent::finished, sweep_.variants[k].name, k, n_, {}, r});
  }

  // Workers not heard from within the timeout are lost; their run goes back to the front of the queue.
  bool drop_silent_workers() {
    bool did = false;
    for (size_t w = 1; w < workers_.size(); ++w) {
      Worker& wk = workers_[w];
      if (!wk.alive || seconds_since(wk.last_heard) <= mpi_.heartbeat_timeout) continue;
      wk.alive = false;
      world_.set_peer_lost();
      if (wk.task) {
        const size_t k = *wk.task;
        wk.task.reset();
        spdlog::warn("rank {} silent for {:.0f} s (dead or hung): its run {} goes back to the queue", w,
                     seconds_since(wk.last_heard), sweep_.variants[k].name);
        if (!finished_[k] && !stopping_) pending_.push_front(k);
      } else {
        spdlog::warn("rank {} silent for {:.0f} s (dead or hung): no more runs for it", w, seconds_since(wk.last_heard));
      }
      did = true;
    }
    return did;
  }

  // Every worker lost: rank 0 runs what is left itself, one run per pass of the loop.
  bool run_locally() {
    if (any_alive() || pending_.empty() || stopping_) return false;
    const size_t k = pending_.front();
    pending_.pop_front();
    const SweepVariant& v = sweep_.variants[k];
    spdlog::warn("no worker left: rank 0 runs {} itself", v.name);
    emit({SweepEvent::started, v.name, k, n_, {}, {}});
    StoreRunOptions o;
    o.sweep = sweep_.name;
    o.variant = v.name;
    o.fidelity = fidelity_;
    o.run.out_dir = options_.out_root / sweep_.name / v.name;
    o.run.threads = mpi_.threads > 0 ? mpi_.threads : world_.default_threads();
    o.run.stop = options_.stop;
    StoredRun r;
    try {
      const RunStore::RunRecord record = execute_run(tasks_[k].scene, tasks_[k].manifest, base_dir_, o, r);
      r.run_id = store_.put_run(record);
    } catch (const std::exception& e) {
      r.status = "failed";
      r.error = e.what();
    }
    finish_task(k, r);
    return true;
  }

  // Idle workers hear from rank 0 every second, so that they notice when it is gone.
  void ping_idle() {
    for (size_t w = 1; w < workers_.size(); ++w)
      if (workers_[w].alive && !workers_[w].task && seconds_since(workers_[w].last_ping) > 1.0) {
        out_.send(static_cast<int>(w), kPing, "{}");
        workers_[w].last_ping = Clock::now();
      }
  }

  // Done: every worker may exit (a lost one too, in case it was only slow; its send is never waited for).
  // With a worker lost, rank 0 ends without MPI_Finalize, and tells the others to do the same.
  void shutdown_workers() {
    std::vector<bool> alive(workers_.size());
    const std::string shutdown = world_.peer_lost() ? R"({"peer_lost": true})" : "{}";
    for (size_t w = 1; w < workers_.size(); ++w) {
      alive[w] = workers_[w].alive;
      out_.send(static_cast<int>(w), kShutdown, shutdown, /*synchronous=*/true);
    }
    if (!out_.drain(alive, mpi_.heartbeat_timeout)) {
      spdlog::warn("some worker did not take its shutdown message");
      world_.set_peer_lost();
    }
  }

  MpiWorld& world_;
  RunStore& store_;
  const Sweep& sweep_;
  const SweepOptions& options_;
  const MpiSweepOptions& mpi_;
  const Fidelity fidelity_;
  const size_t n_;
  const fs::path base_dir_;
  SweepResult result_;
  std::vector<Task> tasks_;
  std::vector<bool> finished_;
  std::deque<size_t> pending_;
  std::vector<Worker> workers_;
  Outbox out_;
  bool stopping_ = false;
};

}  // namespace

SweepResult coordinate_sweep(MpiWorld& world, RunStore& store, const Sweep& sweep, const SweepOptions& options,
                             const MpiSweepOptions& mpi_options) {
  return Coordinator(world, store, sweep, options, mpi_options).run();
}


}  // namespace runout::cluster
