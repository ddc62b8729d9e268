// Static files of the web page (web_files.hpp).
#include "web_files.hpp"

#include <fstream>
#include <map>
#include <sstream>

#include "requests.hpp"

namespace runout::service {

namespace fs = std::filesystem;

namespace {

const std::map<std::string, std::string> kTypes = {
    {".html", "text/html; charset=utf-8"}, {".js", "text/javascript; charset=utf-8"},
    {".mjs", "text/javascript; charset=utf-8"}, {".css", "text/css; charset=utf-8"},
    {".json", "application/json"}, {".png", "image/png"}, {".svg", "image/svg+xml"},
    {".ico", "image/x-icon"}, {".txt", "text/plain; charset=utf-8"}, {".md", "text/plain; charset=utf-8"}};

// Is `p` (canonical) inside `root` (canonical)? Component by component, so /web-root2 is not inside /web-root.
bool inside(const fs::path& root, const fs::path& p) {
  auto r = root.begin(), q = p.begin();
  for (; r != root.end(); ++r, ++q)
    if (q == p.end() || *r != *q) return false;
  return true;
}

}  // namespace

WebRoot::WebRoot(const fs::path& root) {
  std::error_code ec;
  if (!root.empty() && fs::is_directory(root, ec)) {
    root_ = fs::canonical(root, ec);
    exists_ = !ec;
  }
  if (!exists_) root_ = root;
}

bool WebRoot::serves(const std::string& path) const {
  return path == "/" || path == "/web" || path.rfind("/web/", 0) == 0;
}

WebFile WebRoot::get(const std::string& path) const {
  // httplib has already percent-decoded the path, so "%2e%2e" arrives here as "..".
  std::string rel = path == "/" || path == "/web" || path == "/web/" ? "index.html" : path.substr(5);
  if (!rel.empty() && rel.back() == '/') rel += "index.html";
  if (rel.size() > 512) throw ApiError(400, "path", "too long (accepted: at most 512 characters under /web/)");
  std::stringstream parts(rel);
  for (std::string seg; std::getline(parts, seg, '/');) {
    bool plain = !seg.empty() && seg != "." && seg != "..";
    for (unsigned char c : seg) plain = plain && c >= 0x20 && c != 0x7f && c != '\\';
    if (!plain)
      throw ApiError(400, "path",
                     "'" + path.substr(0, 200) +
                         "' is not a file of the web page (accepted: /web/ followed by plain names separated by '/'; "
                         "no '..', '.', empty segments or backslashes)");
  }
  if (!exists_)
    throw ApiError(404, "path", "the web page is not installed: " + root_.string() +
                                    " is not a directory (build the runout_web target, or give --web-root DIR)");
  std::error_code ec;
  const fs::path file = fs::weakly_canonical(root_ / rel, ec);
  if (ec || !inside(root_, file))
    throw ApiError(400, "path", "'" + path.substr(0, 200) + "' resolves outside the web root");
  if (!fs::is_regular_file(file, ec)) throw ApiError(404, "path", "no such file of the web page: " + path.substr(0, 200));
  std::ifstream in(file, std::ios::binary);
  if (!in) throw ApiError(404, "path", "cannot read " + path.substr(0, 200));
  std::ostringstream s;
  s << in.rdbuf();
  WebFile out;
  out.body = s.str();
  auto it = kTypes.find(file.extension().string());
  out.content_type = it == kTypes.end() ? "application/octet-stream" : it->second;
  return out;
}

}  // namespace runout::service
