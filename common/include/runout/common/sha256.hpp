#pragma once
// SHA-256 digests as lowercase hex: of a file's bytes (run manifests record their inputs so) and of a string
// (content hashes of scenes and manifests).
#include <cstddef>
#include <memory>
#include <string>

namespace runout {

// A digest of bytes given in pieces: update() in order, then hex() once (a stream of unknown length, such as a
// raster read through GDAL's virtual file system). Throws std::runtime_error if OpenSSL's SHA-256 is missing.
class Sha256 {
 public:
  Sha256();
  ~Sha256();
  Sha256(const Sha256&) = delete;
  Sha256& operator=(const Sha256&) = delete;
  void update(const void* data, size_t size);
  std::string hex();

 private:
  struct Context;
  std::unique_ptr<Context> ctx_;
};

// Throws std::runtime_error if the file cannot be opened or read.
std::string file_sha256(const std::string& path);
std::string sha256_hex(const std::string& bytes);

}  // namespace runout
