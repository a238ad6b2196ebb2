#include "view/export.h"

#include <spdlog/spdlog.h>

#include "core/error.h"
#include "core/json.h"
#include "io/file_util.h"
#include "view/assets.h"
#include "view/derived.h"

namespace dome::view {

namespace fs = std::filesystem;

std::string Base64(std::string_view bytes) {
  static constexpr char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 3 <= bytes.size(); i += 3) {
    const uint32_t v = uint32_t(uint8_t(bytes[i])) << 16 | uint32_t(uint8_t(bytes[i + 1])) << 8 |
                       uint8_t(bytes[i + 2]);
    out += kAlphabet[v >> 18];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += kAlphabet[v & 63];
  }
  if (i < bytes.size()) {
    uint32_t v = uint32_t(uint8_t(bytes[i])) << 16;
    if (i + 1 < bytes.size()) v |= uint32_t(uint8_t(bytes[i + 1])) << 8;
    out += kAlphabet[v >> 18];
    out += kAlphabet[(v >> 12) & 63];
    out += i + 1 < bytes.size() ? kAlphabet[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

namespace {

class Writer {
 public:
  explicit Writer(fs::path dir) : dir_(std::move(dir)) {}

  void Write(const std::string& url, std::string_view bytes) {
    const fs::path path = dir_ / url;
    std::error_code ec;
    fs::create_directories(path.parent_path(), ec);
    core::Require(!ec, path.parent_path().string(), "cannot create the folder: " + ec.message());
    io::WriteFileAtomically(path, bytes);
    ++summary.files;
    summary.bytes += int64_t(bytes.size());
  }
  // `url`.js: a script that hands the bytes to the page.
  void WritePacked(const std::string& url, std::string_view bytes) {
    Write(url + ".js", "domeBlob(" + core::DumpJson(url) + ", \"" + Base64(bytes) + "\");\n");
  }
  void WritePackedError(const std::string& url, const std::string& why) {
    Write(url + ".js",
          "domeBlobError(" + core::DumpJson(url) + ", " + core::DumpJson(why) + ");\n");
    ++summary.failed_derived;
  }

  ExportSummary summary;

 private:
  fs::path dir_;
};

}  // namespace

ExportSummary ExportStatic(const ViewerIndex& index, const fs::path& assets_dir,
                           const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  core::Require(!ec && fs::is_directory(dir), dir.string(), "cannot create the export folder");
  Writer w(dir);
  for (const char* file : kAssetFiles) w.Write(file, io::ReadFileBytes(assets_dir / file));
  w.Write("index.js", "window.DOME_INDEX = " + IndexJson(index, true) + ";\n");
  for (size_t i = 0; i < index.instants.size(); ++i) {
    const InstantEntry& e = index.instants[i];
    for (const std::string* rel :
         {&e.fused, &e.decimated, &e.textured_glb, &e.textured_obj, &e.textured_png}) {
      if (!rel->empty()) w.WritePacked("out/" + *rel, io::ReadFileBytes(index.out_dir / *rel));
    }
    if (!e.truth_mesh.empty()) {
      for (const MeshVariant v : {MeshVariant::kFused, MeshVariant::kDecimated}) {
        const std::string& rel = v == MeshVariant::kFused ? e.fused : e.decimated;
        if (rel.empty()) continue;
        const std::string url = "derived/error/" + e.name + "/" + VariantName(v) + ".f32";
        try {
          w.WritePacked(url, VertexErrorFile(index, int(i), v));
        } catch (const core::InputError& err) {
          spdlog::warn("dome view --export: {}", err.what());
          w.WritePackedError(url, err.what());
        }
      }
    }
    for (size_t c = 0; c < e.cameras.size(); ++c) {
      const CameraFiles& f = e.cameras[c];
      // derived/<kind>/<instant>/<camera>.png; one that cannot be made is counted.
      auto write_derived = [&](const char* kind, auto&& file) {
        const std::string url =
            std::string("derived/") + kind + "/" + e.name + "/" + index.cameras[c].id + ".png";
        try {
          w.Write(url, file(index, int(i), int(c)));
        } catch (const core::InputError& err) {
          spdlog::warn("dome view --export: {}", err.what());
          ++w.summary.failed_derived;
        }
      };
      if (!f.image.empty())
        w.Write("take/" + f.image, io::ReadFileBytes(*index.take_dir / f.image));
      if (f.mask) write_derived("mask", MaskPreviewFile);
      if (!f.depth_preview.empty()) {
        w.Write("out/" + f.depth_preview, io::ReadFileBytes(index.out_dir / f.depth_preview));
      } else if (!f.depth_map.empty()) {
        write_derived("depth", DepthPreviewFile);
      }
    }
  }
  return w.summary;
}

}  // namespace dome::view
