#include "view/derived.h"

#include <algorithm>
#include <bit>
#include <cstring>
#include <limits>

#include "core/error.h"
#include "core/parallel_for.h"
#include "eval/triangle_bvh.h"
#include "io/depth_tiff.h"
#include "io/image_io.h"
#include "io/ply.h"
#include "silhouette/take_masks.h"
#include "take/take.h"

namespace dome::view {

std::vector<float> VertexDistances(const io::Mesh& mesh, const io::Mesh& reference,
                                   int num_threads) {
  std::vector<float> out(mesh.vertices.size(), std::numeric_limits<float>::infinity());
  if (reference.faces.empty()) return out;
  const eval::TriangleBvh bvh(reference.vertices, reference.faces);
  core::ParallelFor(0, int64_t(mesh.vertices.size()), num_threads, [&](int64_t b, int64_t e) {
    for (int64_t v = b; v < e; ++v)
      out[v] = float(std::sqrt(bvh.Closest(mesh.vertices[v].cast<double>()).distance_sq));
  });
  return out;
}

std::string EncodeFloat32Le(const std::vector<float>& values) {
  static_assert(std::endian::native == std::endian::little, "float32 files are little-endian");
  std::string bytes(values.size() * sizeof(float), '\0');
  if (!values.empty()) std::memcpy(bytes.data(), values.data(), bytes.size());
  return bytes;
}

std::string VertexErrorFile(const ViewerIndex& index, int instant, MeshVariant variant) {
  DOME_CHECK(instant >= 0 && instant < int(index.instants.size()), "instant out of range");
  const InstantEntry& e = index.instants[instant];
  const std::string& rel = variant == MeshVariant::kFused ? e.fused : e.decimated;
  core::Require(!rel.empty(), (index.out_dir / e.name).string(),
                std::string("no ") + VariantName(variant) + " mesh for this instant");
  core::Require(!e.truth_mesh.empty(), e.name, "the take has no truth mesh for this instant");
  const io::Mesh mesh = io::ReadPly(index.out_dir / rel);
  const io::Mesh truth = io::ReadPly(e.truth_mesh);
  return EncodeFloat32Le(VertexDistances(mesh, truth));
}

std::string DepthPreviewFile(const ViewerIndex& index, int instant, int camera) {
  DOME_CHECK(instant >= 0 && instant < int(index.instants.size()), "instant out of range");
  const InstantEntry& e = index.instants[instant];
  DOME_CHECK(camera >= 0 && camera < int(e.cameras.size()), "camera out of range");
  const std::filesystem::path& path = e.cameras[camera].depth_map;
  core::Require(!path.empty(), e.name + "/" + index.cameras[camera].id,
                "no depth map for this camera and instant");
  return io::EncodeDepthPreviewPng(io::ReadDepthMap(path), path.string());
}

std::string MaskPreviewFile(const ViewerIndex& index, int instant, int camera) {
  DOME_CHECK(instant >= 0 && instant < int(index.instants.size()), "instant out of range");
  const InstantEntry& e = index.instants[instant];
  DOME_CHECK(camera >= 0 && camera < int(e.cameras.size()), "camera out of range");
  const std::string& id = index.cameras[camera].id;
  core::Require(e.cameras[camera].mask && index.take_dir.has_value(), e.name + "/" + id,
                "no mask for this camera and instant" +
                    (index.masks_unavailable.empty() ? "" : ": " + index.masks_unavailable));
  // The take of this camera only: opening masks checks every camera's given masks and
  // plates, which a request for one camera's should not read.
  take::Take take = take::OpenTake(*index.take_dir);
  auto& cameras = take.rig.cameras;
  cameras.erase(std::remove_if(cameras.begin(), cameras.end(),
                               [&](const auto& c) { return c.model.id != id; }),
                cameras.end());
  silhouette::TakeMasks masks(std::move(take), silhouette::MaskOptions{});
  const cv::Mat mask = masks.Mask(e.name, id);
  const cv::Mat frame =
      silhouette::ReadFrame(masks.take().FramePath(e.name, id), mask.size(), id).colour;
  return io::EncodePng(silhouette::MaskPreview(frame, mask), io::PngEncoding::kFast);
}

}  // namespace dome::view
