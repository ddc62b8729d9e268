// The shipped studies as base scenes of a fresh service (docs/service.md, "Shipped studies"): the base scene of
// every sweep file under the shipped scenarios folder, its file names made relative to that folder (the scene
// directory, the containment boundary), checked as POST /scenes checks a scene and stored. A catchment takes
// ~13 s to check (GDAL, terrain), so this runs on a thread of its own at the lowest priority, after the
// service already answers.
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <omp.h>

#include "runout/common/sha256.hpp"
#include "server_impl.hpp"

namespace runout::service {

namespace {

// Whether `file` is a sweep file (docs/scene-format.md): an object with a `base` file name and layouts.
std::optional<fs::path> sweep_base(const fs::path& file) {
  std::ifstream in(file);
  const json j = json::parse(in, nullptr, false);
  if (!j.is_object() || !j.contains("base") || !j["base"].is_string() || !(j.contains("variants") || j.contains("factorial")))
    return std::nullopt;
  return fs::path(j["base"].get<std::string>());
}

}  // namespace

std::vector<fs::path> shipped_base_scenes(const fs::path& root) {
  std::vector<fs::path> folders;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(root, ec))
    if (e.is_directory()) folders.push_back(e.path().filename());
  // flume/ first: it is checked in a second, so the page offers it almost at once; then by name.
  std::sort(folders.begin(), folders.end(), [](const fs::path& a, const fs::path& b) {
    return (a != "flume") != (b != "flume") ? a == "flume" : a < b;
  });
  std::vector<fs::path> bases;
  for (const auto& folder : folders) {
    std::vector<fs::path> files;
    for (const auto& e : fs::directory_iterator(root / folder, ec))
      if (e.is_regular_file() && e.path().extension() == ".json") files.push_back(e.path());
    std::sort(files.begin(), files.end());
    for (const auto& f : files)
      if (const auto base = sweep_base(f)) {
        const fs::path rel = (folder / *base).lexically_normal();
        if (std::find(bases.begin(), bases.end(), rel) == bases.end()) bases.push_back(rel);
      }
  }
  return bases;
}

json Server::Impl::shipped_status() const {
  std::lock_guard lock(shipped_mutex);
  return shipped;
}

void Server::Impl::seed_shipped_studies() {
  // Background work: the lowest priority (a thread's nice value on Linux) and one thread, so that jobs and
  // requests go first on a busy machine.
  (void)::setpriority(PRIO_PROCESS, static_cast<id_t>(::syscall(SYS_gettid)), 19);
  omp_set_num_threads(1);
  const fs::path root = opt.scene_dir;
  auto record = [&](const char* list, const json& entry) {
    std::lock_guard lock(shipped_mutex);
    shipped[list].push_back(entry);
  };
  auto stopped = [this] {
    std::lock_guard lock(mutex);
    return stopping;
  };
  for (const auto& rel : shipped_base_scenes(root)) {
    if (stopped()) break;
    try {
      const std::string text = rebase_scene_files(read_file(root / rel), rel.parent_path());
      auto row = queue->find_scene(sha256_hex(text));  // stored by an earlier start: not checked again
      if (!row) {
        const NewScene s = parse_scene_request(text, limits, stopped);
        row = queue->put_scene(s.name, s.content_hash, s.scene_json, json(s.structures).dump()).first;
      }
      record("offered", {{"file", rel.generic_string()}, {"scene_id", row->id}, {"name", row->name}});
      spdlog::info("shipped study {}: scene #{} {}", rel.generic_string(), row->id, row->name);
    } catch (const ApiError& e) {
      record("failed", {{"file", rel.generic_string()}, {"message", scrub(e.field + ": " + e.what())}});
      spdlog::warn("shipped study {} not offered: {}: {}", rel.generic_string(), e.field, scrub(e.what()));
    } catch (const std::exception& e) {
      if (stopped()) break;  // shutting down: not a failure of the scene
      record("failed", {{"file", rel.generic_string()}, {"message", scrub(e.what())}});
      spdlog::warn("shipped study {} not offered: {}", rel.generic_string(), scrub(e.what()));
    }
  }
  std::lock_guard lock(shipped_mutex);
  shipped["status"] = stopped() ? "stopped" : "done";
}

}  // namespace runout::service
