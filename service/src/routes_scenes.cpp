// Routes: /scenes: stored base scenes (server_impl.hpp, docs/service.md).
#include "server_impl.hpp"

namespace runout::service {

void Server::Impl::routes_scenes() {
  // Scenes.
  add("/scenes", "POST", [this](const httplib::Request& req, httplib::Response& res, const std::smatch&) {
    only_params(req, {});
    check_json_body(req);
    const NewScene s = parse_scene_request(req.body, limits);
    std::string structures = json(s.structures).dump();
    auto [row, created] = queue->put_scene(s.name, s.content_hash, s.scene_json, structures);
    res.set_header("Location", kPrefix + "/scenes/" + std::to_string(row.id));
    send_json(res, created ? 201 : 200, scene_json(row, false));
  });
  add("/scenes", "GET", [this](const httplib::Request& req, httplib::Response& res, const std::smatch&) {
    FieldErrors errors;
    only_params(req, {"limit", "cursor"}, errors);
    const PageRequest page = page_request(req, 100, 1000, errors);
    errors.raise();
    auto rows = queue->list_scenes(page.limit + 1, page.cursor);  // one more: is there a next page?
    const std::optional<int64_t> next_key = trim_page(rows, page.limit);
    json list = json::array();
    for (const auto& s : rows) list.push_back(scene_json(s, false));
    const json next = next_page(req, res, next_key);
    send_json(res, 200, {{"scenes", list}, {"limit", page.limit}, {"next", next}});
  });
  add(R"(/scenes/(\d{1,18}))", "GET", [this](const httplib::Request& req, httplib::Response& res, const std::smatch& m) {
    only_params(req, {});
    auto s = queue->get_scene(std::stoll(m[1].str()));
    if (!s) throw ApiError(404, "id", "no scene with id " + m[1].str());
    send_json(res, 200, scene_json(*s, true));
  });
}

}  // namespace runout::service
