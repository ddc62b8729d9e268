// Sweeps handed to an MPI launch command (sweep_launcher.hpp).
#include "sweep_launcher.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <map>
#include <mutex>
#include <regex>
#include <set>
#include <stdexcept>
#include <thread>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "runout/scenarios/store.hpp"
#include "runout/scenarios/study.hpp"

namespace runout::service {

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

std::string quoted(const std::string& s) {  // one shell word
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

fs::path this_executable() {
  std::error_code ec;
  fs::path p = fs::read_symlink("/proc/self/exe", ec);
  return ec ? fs::path("runout") : p;
}

}  // namespace

struct SweepLauncher::Impl {
  std::string command_template;
  int ranks = 2;
  fs::path db, runs_dir, scene_dir, runout;
  JobQueue* queue = nullptr;
  std::mutex mutex;
  bool stopping = false;
  struct Launch {
    pid_t pid = -1;
    std::atomic<bool> done{false};
    std::thread follower;
  };
  std::vector<std::unique_ptr<Launch>> launches;

  void follow(const LaunchedSweep& s, Launch& launch, const fs::path& log, const fs::path& base_file);
};

SweepLauncher::SweepLauncher(std::string command_template, int ranks, fs::path db, fs::path runs_dir,
                             fs::path scene_dir, JobQueue& queue)
    : impl_(std::make_unique<Impl>()) {
  for (const char* needed : {"{sweep}", "{db}", "{out}"})
    if (command_template.find(needed) == std::string::npos)
      throw std::invalid_argument(std::string("RUNOUT_SWEEP_LAUNCHER: must contain ") + needed +
                                  " (placeholders: {ranks} {runout} {sweep} {db} {out}; for example "
                                  "'mpirun -np {ranks} {runout} sweep {sweep} --db {db} --out {out}')");
  const std::regex placeholder(R"(\{[^{}]*\})");
  for (auto it = std::sregex_iterator(command_template.begin(), command_template.end(), placeholder);
       it != std::sregex_iterator(); ++it) {
    const std::string p = it->str();
    if (p != "{ranks}" && p != "{runout}" && p != "{sweep}" && p != "{db}" && p != "{out}")
      throw std::invalid_argument("RUNOUT_SWEEP_LAUNCHER: unknown placeholder " + p +
                                  " (accepted: {ranks} {runout} {sweep} {db} {out})");
  }
  if (ranks < 1 || ranks > 100000)
    throw std::invalid_argument("RUNOUT_SWEEP_RANKS: must be an integer in [1, 100000] (got " + std::to_string(ranks) + ")");
  impl_->command_template = std::move(command_template);
  impl_->ranks = ranks;
  impl_->db = fs::absolute(db);
  impl_->runs_dir = fs::absolute(runs_dir);
  impl_->scene_dir = fs::absolute(scene_dir);
  impl_->runout = this_executable();
  impl_->queue = &queue;
}

SweepLauncher::~SweepLauncher() { stop(); }

fs::path SweepLauncher::out_root(int64_t sweep_id) const {
  return impl_->runs_dir / "service" / ("sweep-" + std::to_string(sweep_id)) / "runs";
}

std::string SweepLauncher::command_for(const fs::path& sweep_file, const std::optional<double>& dp) const {
  const fs::path out = sweep_file.parent_path() / "runs";
  const std::map<std::string, std::string> values = {{"{ranks}", std::to_string(impl_->ranks)},
                                                     {"{runout}", quoted(impl_->runout.string())},
                                                     {"{sweep}", quoted(sweep_file.string())},
                                                     {"{db}", quoted(impl_->db.string())},
                                                     {"{out}", quoted(out.string())}};
  std::string cmd;
  const std::string& t = impl_->command_template;
  for (size_t i = 0; i < t.size();) {
    bool replaced = false;
    for (const auto& [k, v] : values)
      if (t.compare(i, k.size(), k) == 0) {
        cmd += v;
        i += k.size();
        replaced = true;
        break;
      }
    if (!replaced) cmd += t[i++];
  }
  if (dp) {  // an explicit spacing is not a sweep-file fidelity: `runout sweep --dp`, at the end of the line
    char buf[64];
    std::snprintf(buf, sizeof buf, " --dp %.17g", *dp);
    cmd += buf;
  }
  return cmd;
}

void SweepLauncher::launch(const LaunchedSweep& s) {
  Impl& m = *impl_;
  const fs::path dir = m.runs_dir / "service" / ("sweep-" + std::to_string(s.sweep_id));
  fs::create_directories(dir);
  // The base goes next to the scenes (--scene-dir), so that a relative terrain.dem resolves as it does for the
  // in-process jobs; the sweep file names it by its absolute path.
  const fs::path base_file = m.scene_dir / (".runout-sweep-" + std::to_string(s.sweep_id) + ".json");
  const fs::path sweep_file = dir / "sweep.json";
  const fs::path log = dir / "launcher.log";
  {
    std::ofstream(base_file) << s.base_json;
    json variants = json::array();
    for (const auto& v : s.variants) variants.push_back({{"name", v.name}, {"structures", v.structures}});
    json sweep = {{"name", s.name}, {"base", base_file.string()}, {"variants", variants}};
    if (!s.dp) sweep["fidelity"] = s.fidelity;
    if (s.ensemble_json) sweep["ensemble"] = json::parse(*s.ensemble_json);
    std::ofstream(sweep_file) << sweep.dump(2);
  }
  const std::string cmd = command_for(sweep_file, s.dp);
  auto launch = std::make_unique<Impl::Launch>();
  std::lock_guard lock(m.mutex);
  if (m.stopping) return;  // the jobs stay running and are requeued at the next start
  const std::string log_s = log.string();
  const pid_t pid = ::fork();
  if (pid == 0) {  // the child: only async-signal-safe calls until exec
    ::setpgid(0, 0);  // its own process group: stop() signals the launcher and everything it started
    const int fd = ::open(log_s.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) {
      ::dup2(fd, 1);
      ::dup2(fd, 2);
    }
    ::execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  if (pid < 0) throw std::runtime_error("cannot start the sweep launcher (fork failed)");
  ::setpgid(pid, pid);  // also from the parent, so that stop() finds the group even before the child ran
  spdlog::info("sweep {} ({}): launched `{}` (pid {}, log {})", s.sweep_id, s.name, cmd, pid, log_s);
  launch->pid = pid;
  Impl::Launch& l = *launch;
  launch->follower = std::thread([this, s, &l, log, base_file] { impl_->follow(s, l, log, base_file); });
  m.launches.push_back(std::move(launch));
}

void SweepLauncher::Impl::follow(const LaunchedSweep& s, Launch& launch, const fs::path& log, const fs::path& base_file) {
  std::map<int64_t, std::string> hash;  // job id -> manifest hash of its run
  std::map<int64_t, double> duration;
  std::set<int64_t> open;               // jobs still running
  size_t cancelled = 0;
  int status = 0;
  bool exited = false;
  try {
    RunStore store(db);  // this follower's own connection
    for (const auto& j : queue->list(std::nullopt, s.sweep_id, 100000, 0)) {
      const auto full = queue->get(j.id);
      if (!full || full->status != "running") continue;
      Fidelity f;
      f.name = full->fidelity;
      f.dp = full->dp;
      hash[j.id] = make_manifest(full->scene_json, scene_dir, f).hash;
      duration[j.id] = full->duration;
      open.insert(j.id);
    }
    const size_t total = open.size();
    // A job is done when its run is stored completed; cancelled when asked (its run may still be stored).
    auto check = [&] {
      for (auto it = open.begin(); it != open.end();) {
        const int64_t id = *it;
        const auto j = queue->get(id);
        if (!j || j->status != "running") {
          it = open.erase(it);
          continue;
        }
        if (j->cancel_requested) {
          queue->finish(id, "cancelled", std::nullopt, false, "");
          ++cancelled;
          it = open.erase(it);
          continue;
        }
        if (const auto run = find_completed_run(store, hash[id])) {
          const auto metrics = store.metrics(run->run_id);
          auto get = [&](const char* k) { return metrics.count(k) ? metrics.at(k) : 0.0; };
          queue->progress(id, get("simulated_time_s"), duration[id], static_cast<int64_t>(get("steps")),
                          get("wall_time_s"), std::nullopt);
          queue->finish(id, "done", run->run_id, false, "");
          it = open.erase(it);
          continue;
        }
        ++it;
      }
    };
    bool term_sent = false;
    while (!exited) {
      exited = ::waitpid(launch.pid, &status, WNOHANG) == launch.pid;
      check();
      if (!exited && !term_sent && total > 0 && cancelled == total) {  // nothing left worth computing
        ::kill(-launch.pid, SIGTERM);
        term_sent = true;
      }
      if (!exited) std::this_thread::sleep_for(std::chrono::seconds(1));
    }
    check();
    std::string how = WIFEXITED(status) ? "exit code " + std::to_string(WEXITSTATUS(status))
                                        : "signal " + std::to_string(WIFSIGNALED(status) ? WTERMSIG(status) : 0);
    bool stop_requested = false;
    {
      std::lock_guard lock(mutex);
      stop_requested = stopping;
    }
    for (const int64_t id : open) {
      if (stop_requested) {  // server shutdown: back in the queue, as an in-process job would go
        queue->requeue(id);
        continue;
      }
      std::optional<int64_t> run_id;
      std::string error = "the sweep launcher ended (" + how + ") before this run was stored completed; see " + log.string();
      if (const auto id_run = store.find_run(hash[id])) {
        run_id = *id_run;
        if (const auto row = store.get_run(*id_run)) error = "run " + row->status + " (" + how + "); see " + log.string();
      }
      queue->finish(id, "failed", run_id, false, error);
    }
    spdlog::info("sweep {} ({}): launcher ended ({}); {} of {} jobs left unfinished", s.sweep_id, s.name, how,
                 open.size(), total);
  } catch (const std::exception& e) {
    spdlog::error("sweep {} ({}): following the launcher: {}", s.sweep_id, s.name, e.what());
    if (!exited) {
      ::kill(-launch.pid, SIGTERM);
      ::waitpid(launch.pid, &status, 0);
    }
  }
  std::error_code ec;
  fs::remove(base_file, ec);
  launch.done = true;
}

void SweepLauncher::stop() {
  Impl& m = *impl_;
  std::vector<Impl::Launch*> running;
  {
    std::lock_guard lock(m.mutex);
    m.stopping = true;
    for (auto& l : m.launches)
      if (!l->done) running.push_back(l.get());
  }
  for (auto* l : running) ::kill(-l->pid, SIGTERM);  // mpirun passes SIGTERM on to its ranks
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(15);
  for (auto* l : running) {
    while (!l->done && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(std::chrono::milliseconds(50));
    if (!l->done) ::kill(-l->pid, SIGKILL);
  }
  for (auto& l : m.launches)
    if (l->follower.joinable()) l->follower.join();
}

}  // namespace runout::service
