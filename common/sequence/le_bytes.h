// Little-endian fields of the 4D file's records and mesh payloads (sequence/stream.h,
// sequence/mesh_codec.h). dome builds for little-endian x86-64 and AArch64 only, so a
// field is its bytes in memory.
#pragma once

#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>

namespace dome::sequence {

inline void PutU32(std::string* out, uint32_t v) {
  out->append(reinterpret_cast<const char*>(&v), 4);
}
inline void PutF32(std::string* out, float v) { out->append(reinterpret_cast<const char*>(&v), 4); }

// The u32 at `at` (the caller has checked that 4 bytes are there).
inline uint32_t GetU32(std::string_view bytes, size_t at) {
  uint32_t v;
  std::memcpy(&v, bytes.data() + at, 4);
  return v;
}

}  // namespace dome::sequence
