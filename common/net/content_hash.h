// Content addresses of the runtime's blobs (proto/runtime.proto): the SHA-256 of the
// bytes (FIPS 180-4, OpenSSL's implementation), as 64 lowercase hex digits.
#pragma once

#include <string>
#include <string_view>

namespace dome::net {

std::string Sha256Hex(std::string_view bytes);

// True for 64 lowercase hex digits (a well-formed address; says nothing of content).
bool IsSha256Hex(std::string_view text);

}  // namespace dome::net
