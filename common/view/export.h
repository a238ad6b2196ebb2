// `dome view --export DIR`: the page as a static folder that opens from file://.
//
// Chromium refuses XMLHttpRequest/fetch of file:// URLs and WebGL textures from
// file:// images, so an export cannot fetch its index or meshes. It holds instead:
//   DIR/index.html, viewer.js, viewer.css, three/...   the page, as served
//   DIR/index.js                        window.DOME_INDEX = {..., "packed": true};
//   DIR/<url>.js for every mesh, texture and error URL of the index:
//       domeBlob("<url>", "<base64 of the file>");
//     (or domeBlobError("<url>", "<why>") when a derived file could not be made),
//     loaded by the page with a <script> element, which file:// allows;
//   DIR/take/frames/<instant>/<camera>.png, DIR/derived/depth/..., DIR/derived/mask/... and
//   DIR/out/<instant>/preview/...   images, shown with <img>, which file:// allows.
// The same folder also works behind any static HTTP server.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

#include "view/output_index.h"

namespace dome::view {

struct ExportSummary {
  int64_t files = 0;           // files written
  int64_t bytes = 0;           // bytes written
  int64_t failed_derived = 0;  // error/depth/mask files that could not be computed
};

// Writes the export into `dir` (created when missing; files there are replaced).
// Throws core::InputError naming the file when something cannot be read or written.
ExportSummary ExportStatic(const ViewerIndex& index, const std::filesystem::path& assets_dir,
                           const std::filesystem::path& dir);

// RFC 4648 base64 of `bytes` (with '=' padding).
std::string Base64(std::string_view bytes);

}  // namespace dome::view
