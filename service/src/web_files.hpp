#pragma once
// The web page's static files (docs/web.md): GET / is the page (index.html), GET /web/<path> a file under the
// web root. Paths are checked before the file system is touched: every segment must be a plain name
// (no "..", ".", empty, backslash or control characters), and the resolved file must lie inside the
// canonical web root (which also refuses symlinks that point out of it).
#include <filesystem>
#include <string>

namespace runout::service {

struct WebFile {
  std::string body;
  std::string content_type;
};

class WebRoot {
 public:
  explicit WebRoot(const std::filesystem::path& root);  // may not exist (then every file is a 404)
  // The file for a request path ("/", "/web", "/web/", "/web/app.js"). Throws ApiError: 400 for a path that
  // tries to leave the root, 404 for a missing file or a missing root.
  WebFile get(const std::string& request_path) const;
  bool serves(const std::string& request_path) const;  // "/", "/web" or "/web/..."
  const std::filesystem::path& root() const { return root_; }

 private:
  std::filesystem::path root_;  // canonical when it exists
  bool exists_ = false;
};

}  // namespace runout::service
