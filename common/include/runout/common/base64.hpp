#pragma once
// Base64 (RFC 4648, with padding, no line breaks) by OpenSSL's EVP_EncodeBlock: the report embeds its map
// pictures as data: URIs.
#include <string>
#include <string_view>

namespace runout {

std::string base64_encode(std::string_view bytes);

}  // namespace runout
