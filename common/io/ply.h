// PLY (Stanford polygon file format) reading and writing for meshes and point clouds.
//
// The format (Turk 1994, as documented by Paul Bourke): an ASCII header
//
//   ply
//   format ascii|binary_little_endian|binary_big_endian 1.0
//   comment ...                      (and obj_info ...)  anywhere in the header
//   element <name> <count>
//   property <type> <name>           scalar property
//   property list <count-type> <type> <name>
//   ...
//   end_header
//
// followed by the elements in header order, `count` instances each, every instance
// its properties in order. Types: char/int8 uchar/uint8 short/int16 ushort/uint16
// int/int32 uint/uint32 float/float32 double/float64. In ASCII files each instance
// is one line of whitespace-separated numbers; in binary files values are packed with
// no padding, a list being its count followed by that many values.
//
// What ReadPly understands (everything else is skipped correctly, whatever its types):
//  * element "vertex": properties x y z (float or double; converted to float, so
//    coordinates keep ~7 significant digits), optional nx ny nz (all three), optional
//    red green blue [alpha] (also diffuse_red ...): uchar as is, 16-bit scaled by
//    1/257, float/double in [0, 1] scaled by 255. An incomplete set (nx without nz,
//    red without blue) is ignored. Non-finite coordinates are an error.
//  * element "face": the list property vertex_indices (or vertex_index), any integer
//    count and index types; triangles are kept, larger polygons are split as a fan
//    (v0 vi vi+1), faces with fewer than 3 vertices and indices out of range are errors.
// Units are those of the file (dome writes mm). Errors are core::InputError naming the
// file and the header line, or the element, instance, property and (ASCII) line at
// fault; truncation is reported with what was expected.
//
// WritePly writes binary_little_endian (default) or ascii: float x y z, then float nx
// ny nz, uchar red green blue [alpha] when present, and "element face" with "property
// list uchar int vertex_indices" when the mesh has faces (omitted for point clouds).
#pragma once

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "io/mesh.h"

namespace dome::io {

enum class PlyFormat { kAscii, kBinaryLittleEndian, kBinaryBigEndian };

struct PlyWriteOptions {
  // kAscii or kBinaryLittleEndian (big-endian output is not offered).
  PlyFormat format = PlyFormat::kBinaryLittleEndian;
  // Written as "comment <text>" lines (e.g. "units mm"); must not contain newlines.
  std::vector<std::string> comments;
};

Mesh ReadPly(const std::filesystem::path& path);
// Parses a PLY file held in memory; `where` names it in errors.
Mesh ParsePly(std::string_view bytes, const std::string& where);

// The PLY bytes of `mesh`. An inconsistent mesh (Mesh::Inconsistency) or a big-endian
// format request is a programmer error (DOME_CHECK).
std::string EncodePly(const Mesh& mesh, const PlyWriteOptions& options = {});
// Writes atomically; core::InputError naming the file when the folder is missing or
// not writable.
void WritePly(const std::filesystem::path& path, const Mesh& mesh,
              const PlyWriteOptions& options = {});

}  // namespace dome::io
