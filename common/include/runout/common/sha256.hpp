#pragma once
// SHA-256 digests as lowercase hex: of a file's bytes (run manifests record their inputs so) and of a string
// (content hashes of scenes and manifests).
#include <string>

namespace runout {

// Throws std::runtime_error if the file cannot be opened or read.
std::string file_sha256(const std::string& path);
std::string sha256_hex(const std::string& bytes);

}  // namespace runout
