#include "io/ply.h"

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>

#include "core/error.h"
#include "io/file_util.h"

namespace dome::io {
namespace {

// ---------------------------------------------------------------------------------
// Header model.

enum class Type : uint8_t { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

std::optional<Type> ParseType(std::string_view s) {
  if (s == "char" || s == "int8") {
    return Type::kInt8;
  }
  if (s == "uchar" || s == "uint8") {
    return Type::kUint8;
  }
  if (s == "short" || s == "int16") {
    return Type::kInt16;
  }
  if (s == "ushort" || s == "uint16") {
    return Type::kUint16;
  }
  if (s == "int" || s == "int32") {
    return Type::kInt32;
  }
  if (s == "uint" || s == "uint32") {
    return Type::kUint32;
  }
  if (s == "float" || s == "float32") {
    return Type::kFloat32;
  }
  if (s == "double" || s == "float64") {
    return Type::kFloat64;
  }
  return std::nullopt;
}

const char* TypeName(Type t) {
  static constexpr const char* kNames[] = {"char", "uchar", "short", "ushort",
                                           "int",  "uint",  "float", "double"};
  return kNames[static_cast<int>(t)];
}

int TypeSize(Type t) {
  static constexpr int kSizes[] = {1, 1, 2, 2, 4, 4, 4, 8};
  return kSizes[static_cast<int>(t)];
}

bool IsInteger(Type t) { return t != Type::kFloat32 && t != Type::kFloat64; }

struct Property {
  std::string name;
  Type type = Type::kFloat32;  // the value type (of the items, for a list)
  bool is_list = false;
  Type count_type = Type::kUint8;
};

struct Element {
  std::string name;
  int64_t count = 0;
  std::vector<Property> properties;
  int header_line = 0;

  int FindProperty(std::initializer_list<std::string_view> names) const {
    for (std::string_view n : names) {
      for (size_t i = 0; i < properties.size(); ++i) {
        if (properties[i].name == n) {
          return static_cast<int>(i);
        }
      }
    }
    return -1;
  }
  // Fewest bytes one instance can take in a binary file (lists counted as empty).
  int64_t MinBinaryBytes() const {
    int64_t bytes = 0;
    for (const Property& p : properties) {
      bytes += TypeSize(p.is_list ? p.count_type : p.type);
    }
    return bytes;
  }
};

struct Header {
  PlyFormat format = PlyFormat::kAscii;
  std::vector<Element> elements;
  size_t body_offset = 0;  // first byte after "end_header\n"
  int body_line = 0;       // 1-based line number of the first body line (ASCII)
};

std::vector<std::string_view> SplitWords(std::string_view line) {
  std::vector<std::string_view> words;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) {
      ++i;
    }
    const size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t') {
      ++i;
    }
    if (i > start) {
      words.push_back(line.substr(start, i - start));
    }
  }
  return words;
}

// The header is plain text ending at the first "end_header" line; it is capped so a
// binary file that merely starts with "ply" cannot make us scan gigabytes.
constexpr size_t kMaxHeaderBytes = 1 << 20;

Header ParseHeader(std::string_view bytes, const std::string& where) {
  Header header;
  bool have_format = false;
  size_t pos = 0;
  int line_no = 0;
  auto fail = [&](const std::string& what) {
    throw core::InputError(where, "PLY header line " + std::to_string(line_no) + ": " + what);
  };
  while (true) {
    if (pos >= bytes.size() || pos > kMaxHeaderBytes) {
      throw core::InputError(where, line_no <= 1 ? "empty or not a PLY file"
                                                 : "PLY header has no end_header line "
                                                   "(truncated file or not a PLY header)");
    }
    size_t end = bytes.find('\n', pos);
    const size_t next = end == std::string_view::npos ? bytes.size() : end + 1;
    if (end == std::string_view::npos) {
      end = bytes.size();
    }
    std::string_view line = bytes.substr(pos, end - pos);
    if (!line.empty() && line.back() == '\r') {
      line.remove_suffix(1);
    }
    pos = next;
    ++line_no;
    const std::vector<std::string_view> w = SplitWords(line);
    if (line_no == 1) {
      core::Require(w.size() == 1 && w[0] == "ply", where,
                    "not a PLY file (the first line must be 'ply')");
      continue;
    }
    if (w.empty()) {
      continue;  // tolerated: some writers emit blank header lines
    }
    const std::string_view key = w[0];
    if (key == "comment" || key == "obj_info") {
      continue;
    }
    if (key == "format") {
      if (w.size() != 3) {
        fail("expected 'format <ascii|binary_little_endian|binary_big_endian> 1.0'");
      }
      if (w[1] == "ascii") {
        header.format = PlyFormat::kAscii;
      } else if (w[1] == "binary_little_endian") {
        header.format = PlyFormat::kBinaryLittleEndian;
      } else if (w[1] == "binary_big_endian") {
        header.format = PlyFormat::kBinaryBigEndian;
      } else {
        fail("unknown format '" + std::string(w[1]) +
             "'; expected ascii, binary_little_endian or binary_big_endian");
      }
      if (w[2].substr(0, 1) != "1") {
        fail("unsupported PLY version '" + std::string(w[2]) + "'");
      }
      have_format = true;
    } else if (key == "element") {
      if (w.size() != 3) {
        fail("expected 'element <name> <count>'");
      }
      Element e;
      e.name = std::string(w[1]);
      e.header_line = line_no;
      const auto r = std::from_chars(w[2].data(), w[2].data() + w[2].size(), e.count);
      if (r.ec != std::errc() || r.ptr != w[2].data() + w[2].size() || e.count < 0) {
        fail("element count '" + std::string(w[2]) + "' is not a non-negative integer");
      }
      header.elements.push_back(std::move(e));
    } else if (key == "property") {
      if (header.elements.empty()) {
        fail("property before any element");
      }
      Property p;
      if (w.size() >= 2 && w[1] == "list") {
        if (w.size() != 5) {
          fail("expected 'property list <count-type> <item-type> <name>'");
        }
        const auto count_type = ParseType(w[2]);
        const auto item_type = ParseType(w[3]);
        if (!count_type) {
          fail("unknown type '" + std::string(w[2]) + "'");
        }
        if (!item_type) {
          fail("unknown type '" + std::string(w[3]) + "'");
        }
        if (!IsInteger(*count_type)) {
          fail("list count type must be an integer type");
        }
        p.is_list = true;
        p.count_type = *count_type;
        p.type = *item_type;
        p.name = std::string(w[4]);
      } else {
        if (w.size() != 3) {
          fail("expected 'property <type> <name>'");
        }
        const auto type = ParseType(w[1]);
        if (!type) {
          fail("unknown type '" + std::string(w[1]) + "'");
        }
        p.type = *type;
        p.name = std::string(w[2]);
      }
      header.elements.back().properties.push_back(std::move(p));
    } else if (key == "end_header") {
      if (!have_format) {
        fail("end_header before any format line");
      }
      header.body_offset = pos;
      header.body_line = line_no + 1;
      return header;
    } else {
      fail("unknown keyword '" + std::string(key) + "'");
    }
  }
}

// ---------------------------------------------------------------------------------
// Body cursors. Both hand out values as double (exact for every PLY type) and know
// enough about their position to make an error message.

struct Context {
  const std::string* where;
  const Element* element;
  int64_t instance;
};

std::string Locate(const Context& c, const Property* p) {
  std::string s = "element " + c.element->name + " " + std::to_string(c.instance);
  if (p != nullptr) {
    s += ", property " + p->name;
  }
  return s;
}

class BinaryCursor {
 public:
  BinaryCursor(std::string_view body, bool big_endian, const std::string& where)
      : p_(body.data()),
        end_(body.data() + body.size()),
        where_(where),
        swap_(big_endian != (std::endian::native == std::endian::big)) {}

  void CheckRoom(const Element& e) const {
    const int64_t min_bytes = e.MinBinaryBytes();
    const int64_t remaining = end_ - p_;
    if (min_bytes > 0 && e.count > remaining / min_bytes) {
      throw core::InputError(where_, "file is truncated: element " + e.name + " declares " +
                                         std::to_string(e.count) + " instances of at least " +
                                         std::to_string(min_bytes) + " bytes, but only " +
                                         std::to_string(remaining) + " bytes remain");
    }
  }
  void Begin(const Context&) {}
  void End(const Context&) {}

  double Read(Type t, const Context& c, const Property& p) {
    const int size = TypeSize(t);
    if (end_ - p_ < size) {
      throw core::InputError(*c.where, "file is truncated inside " + Locate(c, &p) + " (of " +
                                           std::to_string(c.element->count) + " " +
                                           c.element->name + " instances)");
    }
    unsigned char b[8];
    std::memcpy(b, p_, size);
    p_ += size;
    if (swap_) {
      std::reverse(b, b + size);
    }
    switch (t) {
      case Type::kInt8:
        return static_cast<int8_t>(b[0]);
      case Type::kUint8:
        return b[0];
      case Type::kInt16:
        return Load<int16_t>(b);
      case Type::kUint16:
        return Load<uint16_t>(b);
      case Type::kInt32:
        return Load<int32_t>(b);
      case Type::kUint32:
        return Load<uint32_t>(b);
      case Type::kFloat32:
        return Load<float>(b);
      case Type::kFloat64:
        return Load<double>(b);
    }
    return 0.0;
  }

  void SkipItems(Type t, int64_t n, const Context& c, const Property& p) {
    const int64_t bytes = n * TypeSize(t);
    if (end_ - p_ < bytes) {
      throw core::InputError(*c.where, "file is truncated inside " + Locate(c, &p) + " (of " +
                                           std::to_string(c.element->count) + " " +
                                           c.element->name + " instances)");
    }
    p_ += bytes;
  }

  // Skips a whole element the reader does not use.
  void SkipElement(const Element& e, const std::string& where) {
    CheckRoom(e);
    bool all_scalar = true;
    for (const Property& p : e.properties) {
      all_scalar = all_scalar && !p.is_list;
    }
    if (all_scalar) {  // fixed-size records: one jump
      p_ += e.count * e.MinBinaryBytes();
      return;
    }
    for (int64_t i = 0; i < e.count; ++i) {
      const Context c{&where, &e, i};
      for (const Property& p : e.properties) {
        if (p.is_list) {
          SkipItems(p.type, ListCount(p, c), c, p);
        } else {
          SkipItems(p.type, 1, c, p);
        }
      }
    }
  }

  int64_t ListCount(const Property& p, const Context& c) {
    const double n = Read(p.count_type, c, p);
    if (n < 0) {
      throw core::InputError(*c.where, Locate(c, &p) + ": negative list count");
    }
    return static_cast<int64_t>(n);
  }

  // Upper bound on the items of type `t` left, to bound allocations by the file size.
  int64_t MaxItems(Type t) const { return (end_ - p_) / TypeSize(t); }

 private:
  template <typename T>
  static double Load(const unsigned char* b) {
    T v;
    std::memcpy(&v, b, sizeof(T));
    return static_cast<double>(v);
  }

  const char* p_;
  const char* end_;
  const std::string& where_;
  bool swap_;
};

class AsciiCursor {
 public:
  AsciiCursor(std::string_view body, int first_line, const std::string& where)
      : body_(body), next_line_no_(first_line), where_(where) {}

  void CheckRoom(const Element& e) const {
    // Every instance needs at least one line; a bound before any allocation.
    const int64_t remaining = static_cast<int64_t>(body_.size() - pos_);
    if (e.count > remaining / 2 + 1 && !e.properties.empty()) {
      throw core::InputError(where_, "file is truncated: element " + e.name + " declares " +
                                         std::to_string(e.count) + " instances but only " +
                                         std::to_string(remaining) + " bytes remain");
    }
  }

  void Begin(const Context& c) {
    // Blank lines between instances are tolerated.
    while (true) {
      if (pos_ >= body_.size()) {
        throw core::InputError(*c.where, "file is truncated: it ends before " + Locate(c, nullptr) +
                                             " (header declares " +
                                             std::to_string(c.element->count) + " " +
                                             c.element->name + " instances)");
      }
      size_t end = body_.find('\n', pos_);
      if (end == std::string_view::npos) {
        end = body_.size();
      }
      line_ = body_.substr(pos_, end - pos_);
      pos_ = end + 1;
      line_no_ = next_line_no_++;
      col_ = 0;
      SkipBlanks();
      if (col_ < line_.size()) {
        return;
      }
    }
  }

  void End(const Context& c) {
    SkipBlanks();
    if (col_ < line_.size()) {
      throw core::InputError(*c.where, "line " + std::to_string(line_no_) + ": " +
                                           Locate(c, nullptr) +
                                           " has more values than the header declares");
    }
  }

  double Read(Type t, const Context& c, const Property& p) {
    SkipBlanks();
    if (col_ >= line_.size()) {
      throw core::InputError(*c.where, "line " + std::to_string(line_no_) + ": " + Locate(c, &p) +
                                           ": missing value (the line has "
                                           "fewer values than the header "
                                           "declares)");
    }
    size_t end = col_;
    while (end < line_.size() && !IsBlank(line_[end])) {
      ++end;
    }
    std::string_view token = line_.substr(col_, end - col_);
    col_ = end;
    if (!token.empty() && token[0] == '+') {
      token.remove_prefix(1);
    }
    double v = 0.0;
    const auto r = std::from_chars(token.data(), token.data() + token.size(), v);
    const bool parsed = r.ec == std::errc() && r.ptr == token.data() + token.size();
    if (!parsed || (IsInteger(t) && !IntegerFits(v, t))) {
      throw core::InputError(*c.where, "line " + std::to_string(line_no_) + ": " + Locate(c, &p) +
                                           ": '" + std::string(token) + "' is not a valid " +
                                           TypeName(t));
    }
    return v;
  }

  void SkipItems(Type t, int64_t n, const Context& c, const Property& p) {
    for (int64_t i = 0; i < n; ++i) {
      Read(t, c, p);
    }
  }

  int64_t ListCount(const Property& p, const Context& c) {
    const double n = Read(p.count_type, c, p);
    if (n < 0) {
      throw core::InputError(*c.where, "line " + std::to_string(line_no_) + ": " + Locate(c, &p) +
                                           ": negative list count");
    }
    return static_cast<int64_t>(n);
  }

  void SkipElement(const Element& e, const std::string& where) {
    CheckRoom(e);
    for (int64_t i = 0; i < e.count; ++i) {
      Begin(Context{&where, &e, i});
    }
  }

  // Upper bound on the values left on this line (each takes at least 2 characters).
  int64_t MaxItems(Type) const { return static_cast<int64_t>(line_.size() - col_) / 2 + 1; }

 private:
  static bool IsBlank(char ch) { return ch == ' ' || ch == '\t' || ch == '\r'; }
  void SkipBlanks() {
    while (col_ < line_.size() && IsBlank(line_[col_])) {
      ++col_;
    }
  }
  static bool IntegerFits(double v, Type t) {
    if (v != std::floor(v)) {
      return false;
    }
    switch (t) {
      case Type::kInt8:
        return v >= -128 && v <= 127;
      case Type::kUint8:
        return v >= 0 && v <= 255;
      case Type::kInt16:
        return v >= -32768 && v <= 32767;
      case Type::kUint16:
        return v >= 0 && v <= 65535;
      case Type::kInt32:
        return v >= -2147483648.0 && v <= 2147483647.0;
      case Type::kUint32:
        return v >= 0 && v <= 4294967295.0;
      default:
        return true;
    }
  }

  std::string_view body_;
  size_t pos_ = 0;
  std::string_view line_;
  size_t col_ = 0;
  int64_t line_no_ = 0;
  int64_t next_line_no_;
  const std::string& where_;
};

// ---------------------------------------------------------------------------------
// Element readers, shared by both cursors.

uint8_t ToColorByte(double v, Type t) {
  double scaled = v;
  if (t == Type::kFloat32 || t == Type::kFloat64) {
    scaled = v * 255.0;
  } else if (t == Type::kUint16 || t == Type::kInt16) {
    scaled = v / 257.0;
  }
  if (!(scaled >= 0.0)) {
    return 0;  // also NaN
  }
  return static_cast<uint8_t>(std::lround(std::min(scaled, 255.0)));
}

template <typename Cursor>
void ReadVertices(Cursor& cursor, const Element& e, const std::string& where, Mesh& mesh) {
  const int ix = e.FindProperty({"x"}), iy = e.FindProperty({"y"}), iz = e.FindProperty({"z"});
  const std::pair<int, const char*> required[] = {{ix, "x"}, {iy, "y"}, {iz, "z"}};
  for (const auto& [index, name] : required) {
    if (index < 0) {
      throw core::InputError(where, "PLY header line " + std::to_string(e.header_line) +
                                        ": element vertex has no property " + name);
    }
    if (e.properties[index].is_list) {
      throw core::InputError(where, "PLY header: vertex property " + std::string(name) +
                                        " is a list, expected a scalar");
    }
  }
  int in[3] = {e.FindProperty({"nx", "normal_x"}), e.FindProperty({"ny", "normal_y"}),
               e.FindProperty({"nz", "normal_z"})};
  int ic[4] = {e.FindProperty({"red", "diffuse_red", "r"}),
               e.FindProperty({"green", "diffuse_green", "g"}),
               e.FindProperty({"blue", "diffuse_blue", "b"}), e.FindProperty({"alpha", "a"})};
  auto scalar = [&](int i) { return i >= 0 && !e.properties[i].is_list; };
  // Partial normals or colours are ignored rather than half-filled.
  const bool has_normals = scalar(in[0]) && scalar(in[1]) && scalar(in[2]);
  const bool has_colors = scalar(ic[0]) && scalar(ic[1]) && scalar(ic[2]);
  const bool has_alpha = has_colors && scalar(ic[3]);

  cursor.CheckRoom(e);
  const size_t n = static_cast<size_t>(e.count);
  mesh.vertices.resize(n);
  if (has_normals) {
    mesh.normals.resize(n);
  }
  if (has_colors) {
    mesh.colors.resize(n);
  }
  if (has_alpha) {
    mesh.alphas.resize(n);
  }
  std::vector<double> v(e.properties.size(), 0.0);
  for (int64_t i = 0; i < e.count; ++i) {
    const Context c{&where, &e, i};
    cursor.Begin(c);
    for (size_t k = 0; k < e.properties.size(); ++k) {
      const Property& p = e.properties[k];
      if (p.is_list) {
        cursor.SkipItems(p.type, cursor.ListCount(p, c), c, p);
      } else {
        v[k] = cursor.Read(p.type, c, p);
      }
    }
    cursor.End(c);
    const Eigen::Vector3d xyz(v[ix], v[iy], v[iz]);
    const Eigen::Vector3f xyz_f = xyz.cast<float>();
    if (!xyz_f.allFinite()) {
      throw core::InputError(where, Locate(c, nullptr) + ": coordinates (" +
                                        std::to_string(xyz.x()) + ", " + std::to_string(xyz.y()) +
                                        ", " + std::to_string(xyz.z()) + ") are not finite");
    }
    mesh.vertices[i] = xyz_f;
    if (has_normals) {
      mesh.normals[i] = Eigen::Vector3d(v[in[0]], v[in[1]], v[in[2]]).cast<float>();
    }
    if (has_colors) {
      for (int ch = 0; ch < 3; ++ch) {
        mesh.colors[i][ch] = ToColorByte(v[ic[ch]], e.properties[ic[ch]].type);
      }
    }
    if (has_alpha) {
      mesh.alphas[i] = ToColorByte(v[ic[3]], e.properties[ic[3]].type);
    }
  }
}

template <typename Cursor>
void ReadFaces(Cursor& cursor, const Element& e, int64_t num_vertices, const std::string& where,
               Mesh& mesh) {
  const int il = e.FindProperty({"vertex_indices", "vertex_index"});
  if (il < 0 || !e.properties[il].is_list) {
    throw core::InputError(where, "PLY header line " + std::to_string(e.header_line) +
                                      ": element face has no list property vertex_indices "
                                      "(or vertex_index)");
  }
  if (!IsInteger(e.properties[il].type)) {
    throw core::InputError(where, "PLY header: face vertex indices have type " +
                                      std::string(TypeName(e.properties[il].type)) +
                                      ", expected an integer type");
  }
  cursor.CheckRoom(e);
  mesh.faces.reserve(mesh.faces.size() + static_cast<size_t>(e.count));
  std::vector<int> polygon;
  for (int64_t i = 0; i < e.count; ++i) {
    const Context c{&where, &e, i};
    cursor.Begin(c);
    for (size_t k = 0; k < e.properties.size(); ++k) {
      const Property& p = e.properties[k];
      if (static_cast<int>(k) != il) {
        if (p.is_list) {
          cursor.SkipItems(p.type, cursor.ListCount(p, c), c, p);
        } else {
          cursor.Read(p.type, c, p);
        }
        continue;
      }
      const int64_t count = cursor.ListCount(p, c);
      if (count < 3) {
        throw core::InputError(where, Locate(c, &p) + ": a face has " + std::to_string(count) +
                                          " vertices, expected at least 3");
      }
      if (count > cursor.MaxItems(p.type)) {
        throw core::InputError(where, Locate(c, &p) + ": a face claims " + std::to_string(count) +
                                          " vertices, more than the file holds (truncated?)");
      }
      polygon.resize(static_cast<size_t>(count));
      for (int64_t j = 0; j < count; ++j) {
        const double index = cursor.Read(p.type, c, p);
        if (!(index >= 0 && index < static_cast<double>(num_vertices))) {
          throw core::InputError(where, Locate(c, &p) + ": vertex index " +
                                            std::to_string(static_cast<int64_t>(index)) +
                                            " out of range (the file has " +
                                            std::to_string(num_vertices) + " vertices)");
        }
        polygon[j] = static_cast<int>(index);
      }
      for (int64_t j = 1; j + 1 < count; ++j) {
        mesh.faces.emplace_back(polygon[0], polygon[j], polygon[j + 1]);
      }
    }
    cursor.End(c);
  }
}

template <typename Cursor>
Mesh ReadBody(Cursor& cursor, const Header& header, const std::string& where) {
  Mesh mesh;
  int64_t num_vertices = -1;
  for (const Element& e : header.elements) {
    if (e.name == "vertex") {
      num_vertices = e.count;
    }
  }
  bool vertices_read = false;
  for (const Element& e : header.elements) {
    if (e.name == "vertex" && !vertices_read) {
      ReadVertices(cursor, e, where, mesh);
      vertices_read = true;
    } else if (e.name == "face") {
      if (num_vertices < 0 && e.count > 0) {
        throw core::InputError(where, "PLY header: faces but no vertex element");
      }
      ReadFaces(cursor, e, num_vertices, where, mesh);
    } else {
      cursor.SkipElement(e, where);
    }
  }
  return mesh;
}

// ---------------------------------------------------------------------------------
// Writing.

template <typename T>
void AppendLittleEndian(std::string& out, T value) {
  char b[sizeof(T)];
  std::memcpy(b, &value, sizeof(T));
  if constexpr (std::endian::native == std::endian::big) {
    std::reverse(b, b + sizeof(T));
  }
  out.append(b, sizeof(T));
}

void AppendNumber(std::string& out, float v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof(buf), v);  // shortest round-trip form
  out.append(buf, r.ptr);
}

void AppendNumber(std::string& out, int v) {
  char buf[16];
  const auto r = std::to_chars(buf, buf + sizeof(buf), v);
  out.append(buf, r.ptr);
}

}  // namespace

Mesh ParsePly(std::string_view bytes, const std::string& where) {
  const Header header = ParseHeader(bytes, where);
  const std::string_view body = bytes.substr(header.body_offset);
  if (header.format == PlyFormat::kAscii) {
    AsciiCursor cursor(body, header.body_line, where);
    return ReadBody(cursor, header, where);
  }
  BinaryCursor cursor(body, header.format == PlyFormat::kBinaryBigEndian, where);
  return ReadBody(cursor, header, where);
}

Mesh ReadPly(const std::filesystem::path& path) {
  return ParsePly(ReadFileBytes(path), path.string());
}

std::string EncodePly(const Mesh& mesh, const PlyWriteOptions& options) {
  const std::string problem = mesh.Inconsistency();
  DOME_CHECK(problem.empty(), "EncodePly: inconsistent mesh: " + problem);
  DOME_CHECK(options.format != PlyFormat::kBinaryBigEndian,
             "EncodePly: only ascii and binary_little_endian are written");
  const bool ascii = options.format == PlyFormat::kAscii;
  std::string out = "ply\nformat ";
  out += ascii ? "ascii" : "binary_little_endian";
  out += " 1.0\n";
  for (const std::string& comment : options.comments) {
    DOME_CHECK(comment.find_first_of("\r\n") == std::string::npos,
               "EncodePly: comment with a line break");
    out += "comment " + comment + "\n";
  }
  out += "element vertex " + std::to_string(mesh.vertices.size()) + "\n";
  out += "property float x\nproperty float y\nproperty float z\n";
  if (mesh.HasNormals()) {
    out += "property float nx\nproperty float ny\nproperty float nz\n";
  }
  if (mesh.HasColors()) {
    out += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  }
  if (mesh.HasAlphas()) {
    out += "property uchar alpha\n";
  }
  if (mesh.HasFaces()) {
    out += "element face " + std::to_string(mesh.faces.size()) + "\n";
    out += "property list uchar int vertex_indices\n";
  }
  out += "end_header\n";

  const size_t n = mesh.vertices.size();
  if (!ascii) {
    const size_t vertex_bytes =
        12 + (mesh.HasNormals() ? 12 : 0) + (mesh.HasColors() ? 3 : 0) + (mesh.HasAlphas() ? 1 : 0);
    out.reserve(out.size() + n * vertex_bytes + mesh.faces.size() * 13);
  }
  for (size_t i = 0; i < n; ++i) {
    if (ascii) {
      std::string line;
      for (int k = 0; k < 3; ++k) {
        if (k > 0) {
          line += ' ';
        }
        AppendNumber(line, mesh.vertices[i][k]);
      }
      if (mesh.HasNormals()) {
        for (int k = 0; k < 3; ++k) {
          line += ' ';
          AppendNumber(line, mesh.normals[i][k]);
        }
      }
      if (mesh.HasColors()) {
        for (int k = 0; k < 3; ++k) {
          line += ' ';
          AppendNumber(line, static_cast<int>(mesh.colors[i][k]));
        }
      }
      if (mesh.HasAlphas()) {
        line += ' ';
        AppendNumber(line, static_cast<int>(mesh.alphas[i]));
      }
      out += line;
      out += '\n';
    } else {
      for (int k = 0; k < 3; ++k) {
        AppendLittleEndian(out, mesh.vertices[i][k]);
      }
      if (mesh.HasNormals()) {
        for (int k = 0; k < 3; ++k) {
          AppendLittleEndian(out, mesh.normals[i][k]);
        }
      }
      if (mesh.HasColors()) {
        out.append(reinterpret_cast<const char*>(mesh.colors[i].data()), 3);
      }
      if (mesh.HasAlphas()) {
        out += static_cast<char>(mesh.alphas[i]);
      }
    }
  }
  for (const Eigen::Vector3i& f : mesh.faces) {
    if (ascii) {
      out += "3";
      for (int k = 0; k < 3; ++k) {
        out += ' ';
        AppendNumber(out, f[k]);
      }
      out += '\n';
    } else {
      out += static_cast<char>(3);
      for (int k = 0; k < 3; ++k) {
        AppendLittleEndian(out, static_cast<int32_t>(f[k]));
      }
    }
  }
  return out;
}

void WritePly(const std::filesystem::path& path, const Mesh& mesh, const PlyWriteOptions& options) {
  RequireParentFolder(path);
  WriteFileAtomically(path, EncodePly(mesh, options));
}

}  // namespace dome::io
