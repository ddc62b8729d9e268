// Base64 through libcrypto (base64.hpp), already linked for SHA-256.
#include "runout/common/base64.hpp"

#include <openssl/evp.h>

#include <limits>
#include <stdexcept>

namespace runout {

std::string base64_encode(std::string_view bytes) {
  // EVP_EncodeBlock takes an int length; the report's pictures are a few MB at most.
  if (bytes.size() > static_cast<size_t>(std::numeric_limits<int>::max() / 4 * 3))
    throw std::length_error("base64_encode: " + std::to_string(bytes.size()) + " bytes is more than it encodes at once");
  std::string out(4 * ((bytes.size() + 2) / 3) + 1, '\0');  // + 1: EVP_EncodeBlock writes a terminating NUL
  const int n = EVP_EncodeBlock(reinterpret_cast<unsigned char*>(out.data()),
                                reinterpret_cast<const unsigned char*>(bytes.data()), static_cast<int>(bytes.size()));
  out.resize(static_cast<size_t>(n));
  return out;
}

}  // namespace runout
