#include "stereo/take_stereo.h"

#include <algorithm>
#include <cstring>

#include "core/error.h"
#include "core/parallel_for.h"
#include "io/depth_tiff.h"
#include "io/file_util.h"
#include "io/image_io.h"

namespace dome::stereo {
namespace fs = std::filesystem;

void TakeStereoOptions::Check() const {
  stereo.Check();
  cluster.Check();
  if (coarse_to_fine) coarse_to_fine->Check();
  for (const auto& [id, z] : camera_depth_mm) {
    core::Require(
        std::isfinite(z.first) && std::isfinite(z.second) && z.first > 0 && z.first < z.second,
        "camera_depths", "camera '" + id + "': needs 0 < z_min_mm < z_max_mm");
  }
  if (clip) {
    core::Require((clip_max_mm - clip_min_mm).minCoeff() > 0, "clip_max_mm",
                  "must exceed clip_min_mm on every axis");
    core::Require(std::isfinite(clip_pad_mm) && clip_pad_mm >= 0, "clip_pad_mm",
                  "must be >= 0 mm, got " + std::to_string(clip_pad_mm));
  }
}

cv::Mat DecodeFrame(std::string_view bytes, const std::string& where) {
  // Keep alpha when present: it marks valid pixels.
  return CheckFrame(io::DecodeImage(bytes, io::ImageMode::kUnchanged, where), where);
}

const cv::Mat& CheckFrame(const cv::Mat& image, const std::string& where) {
  if (image.depth() != CV_8U ||
      (image.channels() != 1 && image.channels() != 3 && image.channels() != 4)) {
    throw core::InputError(where, "must be an 8-bit gray, BGR or BGRA image");
  }
  return image;
}

cv::Mat ReadFrame(const fs::path& path) {
  return DecodeFrame(io::ReadFileBytes(path), path.string());
}

namespace {

std::string Suffix(size_t k, int window_px) {
  return k == 0 ? std::string() : "-w" + std::to_string(window_px);
}

}  // namespace

StereoInput LoadStereoInput(const take::Take& take, const std::string& instant,
                            const std::string& camera_id, const ClusterOptions& cluster) {
  const std::vector<int> nbs = SelectCluster(take.rig, camera_id, cluster);
  StereoInput input;
  const int ref = take.rig.Find(camera_id);
  input.reference.camera = take.rig.cameras[ref].model;
  input.reference.image = ReadFrame(take.FramePath(instant, camera_id));
  for (int j : nbs) {
    StereoView v;
    v.camera = take.rig.cameras[j].model;
    v.image = ReadFrame(take.FramePath(instant, v.camera.id));
    input.neighbours.push_back(std::move(v));
  }
  return input;
}

std::vector<StereoFile> EncodeStereoFiles(const StereoResult& result, bool write_previews,
                                          int num_threads) {
  // Each file is encoded on its own: the preview's PNG takes about twice as long as both
  // TIFFs together (a 1280x1024 Robovision map), and the job's other threads would wait. Tasks go in the order
  // preview, depth, reliability so that two threads split one window's files evenly
  // (ParallelFor's chunks are contiguous); files keep the layout order.
  const size_t per_window = write_previews ? 3 : 2;
  std::vector<StereoFile> files(result.range_images.size() * per_window);
  core::ParallelFor(0, int64_t(files.size()), num_threads, [&](int64_t b, int64_t e) {
    for (int64_t t = b; t < e; ++t) {
      const size_t k = size_t(t) / per_window, task = size_t(t) % per_window;
      const size_t kind = write_previews ? (task + 2) % 3 : task;  // 0 depth, 1 rel., 2 preview
      const size_t f = k * per_window + kind;
      const RangeImage& r = result.range_images[k];
      const std::string sfx = Suffix(k, r.window_px);
      const std::string name =
          result.camera + (k == 0 ? "" : " window " + std::to_string(r.window_px));
      StereoFile& out = files[f];
      if (kind == 0) {
        out = {"depth" + sfx + "/" + result.camera + ".tiff",
               io::EncodeDepthTiff(r.depth_mm, "depth map of " + name,
                                   io::DepthTiffEncoding::kFast)};
      } else if (kind == 1) {
        // PackBits: Deflate or LZW cost more CPU than the stereo job's decoding of its
        // frames for a map of noisy floats, whose zeros (no depth) run lengths hold.
        out = {"reliability" + sfx + "/" + result.camera + ".tiff",
               io::EncodeRunLengthFloatTiff(
                   r.reliability, "dome reliability: matching-cost curvature, 0 = no depth",
                   "reliability map of " + name)};
      } else {
        out = {"preview" + sfx + "/" + result.camera + ".png",
               io::EncodeDepthPreviewPng(r.depth_mm, "depth map of " + name)};
      }
    }
  });
  return files;
}

void CheckStereoFiles(const StereoResult& result, bool write_previews,
                      const std::vector<StereoFile>& files, const std::string& where,
                      const std::vector<MapCut>& cuts) {
  DOME_CHECK(cuts.empty() || cuts.size() == result.range_images.size(),
             "one cut per range image, or none");
  std::vector<std::string> expected;
  for (size_t k = 0; k < result.range_images.size(); ++k) {
    const std::string sfx = Suffix(k, result.range_images[k].window_px);
    expected.push_back("depth" + sfx + "/" + result.camera + ".tiff");
    expected.push_back("reliability" + sfx + "/" + result.camera + ".tiff");
    if (write_previews) expected.push_back("preview" + sfx + "/" + result.camera + ".png");
  }
  core::Require(files.size() == expected.size(), where,
                "expected " + std::to_string(expected.size()) + " stereo files, got " +
                    std::to_string(files.size()));
  // Whether the full map `a` is `b` placed at `cut` (zero bits around it), bit for bit.
  const auto same = [](const cv::Mat& a, const cv::Mat& b, const MapCut& cut) {
    if (a.type() != b.type() || a.size() != cut.full) return false;
    const cv::Rect rect(cut.at, b.size());
    if ((rect & cv::Rect(cv::Point(0, 0), cut.full)) != rect) return false;
    const size_t pixel = a.elemSize();
    // OR-ed without an early exit, so that the compiler vectorizes it (a row of zeros
    // is the common case, and a byte-by-byte loop that stops at the first non-zero runs
    // at a byte a cycle).
    const auto zero = [](const uchar* p, size_t n) {
      uchar any = 0;
      for (size_t i = 0; i < n; ++i) any |= p[i];
      return any == 0;
    };
    for (int y = 0; y < a.rows; ++y) {
      const uchar* row = a.ptr(y);
      if (y < rect.y || y >= rect.br().y) {
        if (!zero(row, size_t(a.cols) * pixel)) return false;
        continue;
      }
      if (!zero(row, size_t(rect.x) * pixel) ||
          std::memcmp(row + size_t(rect.x) * pixel, b.ptr(y - rect.y), size_t(b.cols) * pixel) !=
              0 ||
          !zero(row + size_t(rect.br().x) * pixel, size_t(a.cols - rect.br().x) * pixel)) {
        return false;
      }
    }
    return true;
  };
  for (size_t i = 0; i < files.size(); ++i) {
    const StereoFile& f = files[i];
    core::Require(f.path == expected[i], where,
                  "stereo file " + std::to_string(i) + " is '" + f.path.substr(0, 200) +
                      "', expected '" + expected[i] + "'");
    const size_t k = i / (write_previews ? 3 : 2);
    const RangeImage& r = result.range_images[k];
    const auto cut = [&](const cv::Mat& m) {
      return cuts.empty() ? MapCut{{0, 0}, m.size()} : cuts[k];
    };
    const std::string what = where + " " + f.path;
    switch (i % (write_previews ? 3 : 2)) {
      case 0:  // the depth map, bit for bit
        core::Require(same(io::DecodeDepthTiff(f.bytes, what), r.depth_mm, cut(r.depth_mm)), what,
                      "is not the result's depth map");
        break;
      case 1: {
        const cv::Mat rel = io::DecodeImage(f.bytes, io::ImageMode::kUnchanged, what);
        core::Require(same(rel, r.reliability, cut(r.reliability)), what,
                      "is not the result's reliability map");
        break;
      }
      default: {
        // For eyes only: its header is checked, not its pixels.
        const io::PngHeader png = io::ReadPngHeader(f.bytes, what);
        const cv::Size full = cut(r.depth_mm).full;
        core::Require(png.colour_type == 3 && png.bit_depth == 8 && png.width == full.width &&
                          png.height == full.height,
                      what, "is not an 8-bit palette preview of the depth map's size");
      }
    }
  }
}

std::vector<fs::path> WriteStereoFiles(const std::vector<StereoFile>& files,
                                       const std::string& instant, const fs::path& out_dir) {
  std::vector<fs::path> written;
  for (const StereoFile& f : files) {
    const fs::path path = out_dir / instant / f.path;
    std::error_code ec;
    fs::create_directories(path.parent_path(), ec);
    core::Require(!ec, path.parent_path().string(), "cannot create folder: " + ec.message());
    io::WriteFileAtomically(path, f.bytes);
    if (f.path.rfind("depth", 0) == 0) written.push_back(path);
  }
  return written;
}

std::vector<fs::path> WriteStereoResult(const StereoResult& result, const std::string& instant,
                                        const fs::path& out_dir, bool write_previews) {
  return WriteStereoFiles(EncodeStereoFiles(result, write_previews), instant, out_dir);
}

}  // namespace dome::stereo
