#include "pipeline/stages.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <optional>

#include "core/error.h"
#include "core/json.h"
#include "core/parallel_for.h"
#include "fusion/hull_fusion.h"
#include "io/depth_tiff.h"
#include "io/ply.h"
#include "mesh/gltf.h"
#include "mesh/marching_cubes.h"
#include "pipeline/ideal_greys.h"
#include "stereo/coarse_to_fine.h"
#include "take/crop.h"

namespace dome::pipeline {

namespace {

// Coarse-to-fine stereo with a clip box: every view cut to where the box (grown by its
// pad) projects in it, with half a window and a coarse tile's worth of margin, as
// `dome import --crop-box` cuts frames. No depth outside the box is kept, and no point
// of the box projects outside a cut, so only pixels that cannot count are dropped; the
// greys are decoded, undistorted and stretched, and the coarse pass searched, over the
// cut alone (Robovision: the object and its holder, about half of each frame). A view
// that does not see the box keeps its whole image. The depths go back to their place in
// the whole image. Search bounds (whole reference grid) are cut with the reference.
stereo::StereoResult CoarseToFineInBox(const stereo::StereoInput& input,
                                       const stereo::StereoOptions& o,
                                       const stereo::CoarseToFineOptions& c2f,
                                       const stereo::SearchBounds* bounds,
                                       const std::vector<std::string>& grey_keys,
                                       stereo::CoarseToFineStats* stats) {
  take::CropBox box;
  box.min_mm = c2f.clip_min_mm.array() - c2f.clip_pad_mm;
  box.max_mm = c2f.clip_max_mm.array() + c2f.clip_pad_mm;
  const int half = *std::max_element(o.window_sizes_px.begin(), o.window_sizes_px.end()) / 2;
  box.margin_px = std::max(box.margin_px, half + c2f.coarse_factor);
  auto cut = [&](const stereo::StereoView& v, cv::Rect* rect) {
    *rect = cv::Rect(0, 0, v.camera.width_px, v.camera.height_px);
    // An image of another size than its camera's is refused, named, by the stereo.
    if (v.image.cols != v.camera.width_px || v.image.rows != v.camera.height_px) return v;
    const cv::Rect seen = take::BoxImageRect(v.camera, box);
    if (seen.empty()) return v;
    *rect = seen;
    return stereo::StereoView{take::CropCamera(v.camera, seen), v.image(seen)};
  };
  stereo::StereoInput in;
  std::vector<cv::Rect> rects(1 + input.neighbours.size());
  in.reference = cut(input.reference, &rects[0]);
  for (size_t i = 0; i < input.neighbours.size(); ++i)
    in.neighbours.push_back(cut(input.neighbours[i], &rects[1 + i]));
  const cv::Rect& ref_rect = rects[0];
  if (grey_keys.size() == rects.size()) {
    // The cut views' greys from the process's store, those not there made side by side
    // (each is one thread's work: undistortion, the stretch's percentiles).
    core::ParallelFor(0, int64_t(rects.size()), o.num_threads, [&](int64_t b, int64_t e) {
      for (int64_t i = b; i < e; ++i) {
        stereo::StereoView& v = i == 0 ? in.reference : in.neighbours[size_t(i) - 1];
        v.ideal_grey = SharedIdealGrey(CutGreyKey(grey_keys[size_t(i)], rects[size_t(i)]), v, o,
                                       "view '" + v.camera.id + "'");
      }
    });
  }
  const int f = c2f.coarse_factor;
  const bool whole = ref_rect.width == input.reference.camera.width_px &&
                     ref_rect.height == input.reference.camera.height_px;
  if (whole || ref_rect.width < 4 * f || ref_rect.height < 4 * f)
    return stereo::ComputeDepthCoarseToFine(input, o, c2f, stats, bounds);
  // The ideal grid of a cut camera is the whole camera's, shifted by the cut's corner.
  std::optional<stereo::SearchBounds> cut_bounds;
  if (bounds) cut_bounds = stereo::SearchBounds{bounds->near_far_mm(ref_rect).clone()};
  stereo::StereoResult cropped = stereo::ComputeDepthCoarseToFine(
      in, o, c2f, stats, cut_bounds ? &*cut_bounds : nullptr);
  const int width = input.reference.camera.width_px, height = input.reference.camera.height_px;
  for (auto& ri : cropped.range_images) {
    cv::Mat depth(height, width, CV_32FC1, cv::Scalar(0));
    cv::Mat reliability(height, width, CV_32FC1, cv::Scalar(0));
    ri.depth_mm.copyTo(depth(ref_rect));
    ri.reliability.copyTo(reliability(ref_rect));
    ri.depth_mm = depth;
    ri.reliability = reliability;
    ri.density = double(cv::countNonZero(depth)) / (double(width) * height);
  }
  return cropped;
}

// Stereo with the options as given (the camera's own range applied).
stereo::StereoResult StereoLimited(const stereo::StereoInput& input,
                                   const stereo::TakeStereoOptions& options,
                                   const std::string& where, const MakeSearchBounds& bounds,
                                   const std::vector<std::string>& grey_keys) {
  stereo::StereoResult result;
  stereo::StereoOptions o = options.stereo;
  if (options.coarse_to_fine) {
    stereo::ClipDepthRange(*options.coarse_to_fine, input.reference.camera, where, &o);
  } else if (options.clip) {
    stereo::ClipDepthRangeToVisibleBox(options.clip_min_mm, options.clip_max_mm,
                                       options.clip_pad_mm, input.reference.camera,
                                       where + ": clip_min_mm", &o);
  }
  std::optional<stereo::SearchBounds> sb;
  if (bounds) sb = bounds(o.z_min_mm, o.z_max_mm);
  if (options.coarse_to_fine) {
    const stereo::SearchBounds* b = sb ? &*sb : nullptr;
    stereo::CoarseToFineStats st;
    result = options.coarse_to_fine->clip
                 ? CoarseToFineInBox(input, o, *options.coarse_to_fine, b, grey_keys, &st)
                 : stereo::ComputeDepthCoarseToFine(input, o, *options.coarse_to_fine, &st, b);
    spdlog::debug("{}: coarse to fine: {} coarse levels, {} of {} tiles matched ({} filled), "
                  "{:.1f} levels a tile, {:.3f} s coarse, {:.3f} s tiles",
                  where, st.coarse_levels, st.tiles_matched, st.tiles, st.tiles_filled,
                  st.mean_tile_levels, st.coarse_seconds, st.fine_seconds);
  } else if (sb) {
    stereo::CoarseToFineStats st;
    result = stereo::ComputeDepthBounded(input, o, *sb, &st);
    spdlog::debug("{}: bounded search: {} of {} tiles matched, {:.1f} levels a tile (at most {}), "
                  "{:.3f} s preparing, {:.3f} s matching",
                  where, st.tiles_matched, st.tiles, st.mean_tile_levels, result.num_levels,
                  result.prepare_seconds, result.match_seconds);
  } else {
    result = stereo::ComputeDepth(input, o);
  }
  result.camera = input.reference.camera.id;
  return result;
}

}  // namespace

stereo::StereoResult Stereo(const stereo::StereoInput& input,
                            const stereo::TakeStereoOptions& options, const std::string& where,
                            const MakeSearchBounds& bounds,
                            const std::vector<std::string>& grey_keys) {
  stereo::TakeStereoOptions limited = options;
  const auto range = options.camera_depth_mm.find(input.reference.camera.id);
  if (range != options.camera_depth_mm.end()) {
    auto& s = limited.stereo;
    s.z_min_mm = std::max(s.z_min_mm, range->second.first);
    s.z_max_mm = std::min(s.z_max_mm, range->second.second);
    core::Require(s.z_min_mm < s.z_max_mm, where + ": camera_depths",
                  "camera '" + input.reference.camera.id + "': its range misses the session's");
  }
  return StereoLimited(input, limited, where, bounds, grey_keys);
}

std::vector<stereo::StereoResult> RunTakeStereo(const std::filesystem::path& take_dir,
                                                const std::string& camera_id,
                                                const std::string& instant,
                                                const std::filesystem::path& out_dir,
                                                const stereo::TakeStereoOptions& options) {
  options.Check();
  const take::Take take = take::OpenTake(take_dir);
  std::vector<std::string> instants = take.instants;
  if (!instant.empty()) {
    core::Require(std::find(instants.begin(), instants.end(), instant) != instants.end(),
                  "--instant", "'" + instant + "' is not an instant of " + take_dir.string());
    instants = {instant};
  }
  std::vector<std::string> cameras;
  if (!camera_id.empty()) {
    core::Require(take.rig.Find(camera_id) >= 0, "--camera",
                  "camera '" + camera_id + "' is not in the rig of " + take_dir.string());
    cameras = {camera_id};
  } else {
    for (const auto& c : take.rig.cameras) cameras.push_back(c.model.id);
  }
  std::vector<stereo::StereoResult> results;
  for (const auto& t : instants) {
    for (const auto& cam : cameras) {
      const stereo::StereoInput input = stereo::LoadStereoInput(take, t, cam, options.cluster);
      stereo::StereoResult r = Stereo(input, options, t + " " + cam);
      stereo::WriteStereoResult(r, t, out_dir, options.write_previews);
      const std::string brief = r.BriefReport();
      spdlog::info("{} {}", t, brief.substr(0, brief.size() - 1));
      results.push_back(std::move(r));
    }
  }
  return results;
}

namespace {

// The bounding rectangle of the depths (> 0) of `depth_mm`; empty without a depth.
cv::Rect DepthBounds(const cv::Mat& depth_mm) {
  int x0 = depth_mm.cols, y0 = depth_mm.rows, x1 = -1, y1 = -1;
  for (int y = 0; y < depth_mm.rows; ++y) {
    const float* d = depth_mm.ptr<float>(y);
    for (int x = 0; x < depth_mm.cols; ++x) {
      if (!(d[x] > 0)) continue;
      x0 = std::min(x0, x);
      x1 = std::max(x1, x);
      y0 = std::min(y0, y);
      y1 = std::max(y1, y);
    }
  }
  if (x1 < 0) return {};
  return cv::Rect(x0, y0, x1 - x0 + 1, y1 - y0 + 1);
}

// DepthBounds (in a map of size `full` when `depth_mm` is its rectangle at `at`) grown
// by one pixel on every side and clipped to the image; empty without a depth.
cv::Rect DepthRect(const cv::Mat& depth_mm, cv::Point at, cv::Size full) {
  const cv::Rect b = DepthBounds(depth_mm);
  if (b.empty()) return {};
  return cv::Rect(at.x + b.x - 1, at.y + b.y - 1, b.width + 2, b.height + 2) &
         cv::Rect(cv::Point(0, 0), full);
}

cv::Rect DepthRect(const cv::Mat& depth_mm) { return DepthRect(depth_mm, {0, 0}, depth_mm.size()); }

}  // namespace

std::optional<fusion::RangeImage> CutRangeImage(const geometry::TsaiCamera& camera,
                                                const cv::Mat& depth_rect,
                                                const stereo::MapCut& cut,
                                                const std::string& where) {
  core::Require(cut.full.width == camera.width_px && cut.full.height == camera.height_px, where,
                "depth map is " + std::to_string(cut.full.width) + "x" +
                    std::to_string(cut.full.height) + " but camera " + camera.id + " is " +
                    std::to_string(camera.width_px) + "x" + std::to_string(camera.height_px));
  // Outside the rectangle the map is 0, a valid value: the rectangle's are the ones to
  // check.
  if (depth_rect.empty()) return std::nullopt;  // no depth (an empty rectangle)
  io::CheckDepthMap(depth_rect, where, cut.at);
  const cv::Rect rect = DepthRect(depth_rect, cut.at, cut.full);
  if (rect.empty()) return std::nullopt;
  fusion::RangeImage image;
  image.camera = take::CropCamera(camera, rect);
  image.depth_mm = cv::Mat(rect.size(), CV_32FC1, cv::Scalar(0));
  const cv::Rect given(cut.at, depth_rect.size());
  const cv::Rect both = given & rect;
  depth_rect(both - cut.at).copyTo(image.depth_mm(both - rect.tl()));
  image.where = where;
  return image;
}

std::unique_ptr<PreparedFusion> PrepareFusion(const fusion::VolumeGrid& grid,
                                              std::vector<fusion::RangeImage> images,
                                              const fusion::FusionOptions& options,
                                              std::shared_ptr<const silhouette::VisualHull> hull,
                                              const fusion::HullFusionOptions& hull_options) {
  auto prepared = std::make_unique<PreparedFusion>();
  // The integrator builds per-pixel tables of every image; only the rectangle of an
  // image's depths matters (a voxel projecting onto a pixel without a depth and one
  // projecting outside the image are both left alone), so each image is cut to it, one
  // pixel kept around for the quads along its border. An image without depths adds
  // nothing and is left out.
  for (fusion::RangeImage& image : images) {
    fusion::CheckRangeImage(image);  // named before it is cut
    const cv::Rect rect = DepthRect(image.depth_mm);
    if (rect.empty()) continue;
    image.camera = take::CropCamera(image.camera, rect);
    image.depth_mm = image.depth_mm(rect).clone();
    if (!image.weight.empty()) image.weight = image.weight(rect).clone();
    prepared->images.push_back(std::move(image));
  }
  prepared->integrator = std::make_unique<fusion::Integrator>(grid, prepared->images, options);
  prepared->hull = std::move(hull);
  prepared->hull_options = hull_options;
  prepared->hull_options.num_threads = options.num_threads;  // checked by ApplyHull
  prepared->options = options;
  return prepared;
}

const fusion::Slab& FuseSlab(const PreparedFusion& prepared, fusion::Slab* slab, int k0, int k1,
                             const fusion::Slab* previous, const std::string& where,
                             fusion::TemporalCarryStats* carried, int num_threads) {
  if (num_threads <= 0) num_threads = prepared.options.num_threads;
  prepared.integrator->IntegrateSlab(k0, k1, slab, num_threads);
  // The previous evidence before the hull: where this instant's silhouettes say free
  // space, the hull's rule overrides what an earlier instant saw there.
  if (previous && !prepared.change_views.empty()) {
    fusion::CarryStill(prepared.integrator->grid(), *previous, prepared.change_views,
                       prepared.carry, where, slab, carried);
  }
  if (prepared.hull) {
    fusion::HullFusionOptions hull_options = prepared.hull_options;
    hull_options.num_threads = num_threads;
    fusion::ApplyHull(prepared.integrator->grid(), *prepared.hull, prepared.photo_hull.get(),
                      prepared.options, hull_options, slab);
  }
  return *slab;
}

int SlabCount(const fusion::VolumeGrid& grid, int slab_planes) {
  return (grid.nz + slab_planes - 1) / slab_planes;
}

std::pair<int, int> SlabPlanes(const fusion::VolumeGrid& grid, int slab_planes, int s) {
  return {s * slab_planes, std::min(grid.nz, (s + 1) * slab_planes)};
}

io::Mesh Surface(const fusion::VolumeGrid& grid, int num_slabs,
                 const std::function<std::shared_ptr<const fusion::Slab>(int)>& slab,
                 const mesh::SmoothOptions& smooth) {
  mesh::StreamingMarchingCubes mc(grid);
  for (int s = 0; s < num_slabs; ++s) mc.AddSlab(*slab(s));
  core::Require(mc.next_plane() == grid.nz, "surface",
                "slabs cover planes 0.." + std::to_string(mc.next_plane()) + ", expected " +
                    std::to_string(grid.nz));
  io::Mesh surface = mc.Finish();
  mesh::SmoothTaubin(smooth, &surface);
  return surface;
}

io::Mesh Decimate(const io::Mesh& surface, const mesh::DecimationOptions& options,
                  mesh::DecimationSummary* summary) {
  options.Check();
  if (options.target_ratio == 1.0 && options.target_triangles <= 0) return surface;
  return mesh::Decimate(surface, options, summary);
}

namespace {

// Pixels kept around the mesh's projection: bilinear samples need the next pixel, and
// an edge between two vertices bends a little under lens distortion.
constexpr int kTextureCutMarginPx = 16;

// The rectangle of `camera`'s image the mesh's vertices project into, grown by
// kTextureCutMarginPx and clipped to the image; the whole image when a vertex is not in
// front of the camera (the projection of its triangles is then unbounded) or the mesh
// projects nowhere inside it.
cv::Rect MeshImageRect(const geometry::TsaiCamera& camera, const io::Mesh& mesh) {
  const cv::Rect whole(0, 0, camera.width_px, camera.height_px);
  double lo_u = INFINITY, lo_v = INFINITY, hi_u = -INFINITY, hi_v = -INFINITY;
  for (const auto& v : mesh.vertices) {
    Eigen::Vector2d px;
    if (!camera.Project(v.cast<double>(), &px) || !std::isfinite(px.x()) || !std::isfinite(px.y()))
      return whole;
    lo_u = std::min(lo_u, px.x()), hi_u = std::max(hi_u, px.x());
    lo_v = std::min(lo_v, px.y()), hi_v = std::max(hi_v, px.y());
  }
  if (!(lo_u <= hi_u)) return whole;
  const cv::Rect rect = take::GrownPixelRect(camera, lo_u, lo_v, hi_u, hi_v, kTextureCutMarginPx);
  return rect.empty() ? whole : rect;
}

}  // namespace

TextureResult Texture(io::Mesh decimated, const std::vector<mesh::TextureView>& views,
                      const mesh::TextureOptions& options, bool atlas) {
  // Each view cut to where the mesh projects, as the stereo of a clipped volume cuts its
  // views: the z-buffers, colour conversions and lens resampling then cover only pixels
  // that can colour the mesh (Robovision: about a third of each frame).
  std::vector<mesh::TextureView> cut = views;
  for (auto& v : cut) {
    if (v.image.cols != v.camera.width_px || v.image.rows != v.camera.height_px) continue;
    const cv::Rect rect = MeshImageRect(v.camera, decimated);
    if (rect.width == v.camera.width_px && rect.height == v.camera.height_px) continue;
    v.image = v.image(rect);
    v.camera = take::CropCamera(v.camera, rect);
  }
  TextureResult result;
  result.coloured = std::move(decimated);
  result.atlas = mesh::ColourAndAtlas(&result.coloured, cut, options, atlas);
  return result;
}

std::vector<NamedFile> TexturedFiles(const mesh::TexturedMesh& textured, int num_threads) {
  const std::string stem = std::filesystem::path(kTexturedObj).stem().string();
  mesh::TexturedObjFiles obj = mesh::EncodeTexturedObj(textured, stem, num_threads);
  // The GLB holds the PNG file's bytes: the atlas is encoded once (it was encoded again,
  // faster and a third larger, for the GLB: about a quarter of the files' time on
  // Robovision).
  std::string glb = mesh::EncodeGlb(textured, &obj.png);
  return {{kTexturedObj, std::move(obj.obj)},
          {kTexturedMtl, std::move(obj.mtl)},
          {kTexturedPng, std::move(obj.png)},
          {kTexturedGlb, std::move(glb)}};
}

std::string DecimationSummaryJson(const mesh::DecimationSummary& s) {
  const core::Json j = {{"triangles_in", s.triangles_in},
                        {"triangles_out", s.triangles_out},
                        {"components_removed", s.components_removed},
                        {"triangles_removed", s.triangles_removed},
                        {"specks_removed", s.specks_removed},
                        {"speck_triangles", s.speck_triangles},
                        {"components_deleted", s.components_deleted},
                        {"triangles_deleted", s.triangles_deleted},
                        {"error_mm", s.error_mm},
                        {"seconds", s.seconds}};
  return core::DumpJson(j);
}

std::string EncodeMeshPly(const io::Mesh& mesh) {
  return io::EncodePly(mesh, {io::PlyFormat::kBinaryLittleEndian, {"units mm"}});
}

}  // namespace dome::pipeline
