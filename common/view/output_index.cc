#include "view/output_index.h"

#include <algorithm>
#include <set>
#include <system_error>

#include "core/error.h"
#include "core/json.h"
#include "silhouette/take_masks.h"
#include "take/take.h"
#include "take/timecode.h"

namespace dome::view {

namespace fs = std::filesystem;

namespace {

bool IsFile(const fs::path& p) {
  std::error_code ec;
  return fs::is_regular_file(p, ec);
}

// Sub-folders of `dir` named like instants (others are ignored).
std::vector<std::string> InstantFolders(const fs::path& dir) {
  std::vector<std::string> names;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (it->is_directory(ec) && take::ParseInstantName(name)) names.push_back(name);
  }
  return names;
}

core::Json Url(const std::string& prefix, const std::string& relative) {
  return relative.empty() ? core::Json() : core::Json(prefix + relative);
}

core::Json Point(const Eigen::Vector3d& p) { return {p.x(), p.y(), p.z()}; }

}  // namespace

CameraFrustum FrustumOf(const geometry::TsaiCamera& camera, double depth_mm) {
  CameraFrustum f;
  f.id = camera.id;
  f.width_px = camera.width_px;
  f.height_px = camera.height_px;
  f.centre_mm = camera.CentreWorld();
  // Pixel centres are integers, so the image's outer edges are at -0.5 and size - 0.5.
  const double x0 = -0.5, y0 = -0.5, x1 = camera.width_px - 0.5, y1 = camera.height_px - 0.5;
  const Eigen::Vector2d px[4] = {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}};
  for (int k = 0; k < 4; ++k) f.corners_mm[k] = camera.BackProjectAtDepth(px[k], depth_mm);
  return f;
}

double DefaultFrustumDepthMm(const geometry::Rig& rig) {
  double extent = 0.0;
  for (size_t i = 0; i < rig.cameras.size(); ++i)
    for (size_t j = i + 1; j < rig.cameras.size(); ++j)
      extent = std::max(
          extent, (rig.cameras[i].model.CentreWorld() - rig.cameras[j].model.CentreWorld()).norm());
  return extent > 0.0 ? 0.08 * extent : 300.0;
}

const char* VariantName(MeshVariant variant) {
  return variant == MeshVariant::kFused ? "fused" : "decimated";
}

int ViewerIndex::FindInstant(const std::string& name) const {
  for (size_t i = 0; i < instants.size(); ++i)
    if (instants[i].name == name) return int(i);
  return -1;
}

int ViewerIndex::FindCamera(const std::string& id) const {
  for (size_t i = 0; i < cameras.size(); ++i)
    if (cameras[i].id == id) return int(i);
  return -1;
}

ViewerIndex BuildIndex(const fs::path& out_dir, const std::optional<fs::path>& take_dir,
                       const IndexOptions& options) {
  core::Require(options.error_range_mm > 0, "--error-range-mm", "must be positive");
  core::Require(options.play_rate_hz > 0, "--rate", "must be positive");
  std::error_code ec;
  core::Require(fs::is_directory(out_dir, ec), out_dir.string(),
                "expected an output folder (OUT/<instant>/mesh.ply, ...)");
  ViewerIndex index;
  index.out_dir = fs::canonical(out_dir);
  index.options = options;
  std::set<std::string> names;
  for (const auto& n : InstantFolders(index.out_dir)) names.insert(n);
  std::optional<take::Take> take;
  if (take_dir) {
    take = take::OpenTake(*take_dir);
    index.take_dir = fs::canonical(*take_dir);
    names.insert(take->instants.begin(), take->instants.end());
    const double depth =
        options.frustum_depth_mm > 0 ? options.frustum_depth_mm : DefaultFrustumDepthMm(take->rig);
    for (const auto& rc : take->rig.cameras) index.cameras.push_back(FrustumOf(rc.model, depth));
    // Each camera's mask source from which files exist (no image is read: the index
    // is rebuilt on every page load); a take without any source is shown without
    // masks, saying why. A malformed given mask or plate is named when its mask is
    // asked for (derived.h).
    index.mask_sources.assign(index.cameras.size(), "");
    try {
      const auto sources = silhouette::DecideMaskSources(*take);
      for (size_t c = 0; c < index.cameras.size(); ++c)
        index.mask_sources[c] = silhouette::MaskSourceName(sources.at(index.cameras[c].id));
    } catch (const core::InputError& e) {
      index.masks_unavailable = e.what();
    }
  }
  // HH-MM-SS-FF names sort in time order as strings.
  for (const std::string& name : names) {
    InstantEntry e;
    e.name = name;
    e.label = take::ParseInstantName(name)->Text();
    const fs::path dir = index.out_dir / name;
    auto present = [&](const std::string& file) {
      return IsFile(dir / file) ? name + "/" + file : std::string();
    };
    e.fused = present("mesh.ply");
    e.decimated = present("mesh_decimated.ply");
    e.textured_glb = present("textured.glb");
    e.textured_obj = present("textured.obj");
    e.textured_png = present("textured.png");
    if (take) {
      if (IsFile(take->TruthMeshPath(name))) e.truth_mesh = take->TruthMeshPath(name);
      for (const auto& cam : index.cameras) {
        CameraFiles c;
        if (IsFile(take->FramePath(name, cam.id)))
          c.image = fs::relative(take->FramePath(name, cam.id), *index.take_dir).string();
        const std::string preview = name + "/preview/" + cam.id + ".png";
        if (IsFile(index.out_dir / preview)) c.depth_preview = preview;
        const fs::path stereo = dir / "depth" / (cam.id + ".tiff");
        const fs::path truth = take->TruthDepthPath(name, cam.id);
        if (IsFile(stereo)) {
          c.depth_map = stereo;
          c.depth_source = "stereo";
        } else if (IsFile(truth)) {
          c.depth_map = truth;
          c.depth_source = "truth";
        }
        if (!c.depth_preview.empty()) c.depth_source = "stereo";
        c.mask = !c.image.empty() && !index.mask_sources[e.cameras.size()].empty();
        e.cameras.push_back(std::move(c));
      }
    }
    index.instants.push_back(std::move(e));
  }
  for (const auto& entry : fs::directory_iterator(index.out_dir, ec)) {
    if (entry.path().extension() == ".dome4d" && IsFile(entry.path()))
      index.sequences.push_back(entry.path().filename().string());
  }
  std::sort(index.sequences.begin(), index.sequences.end());
  return index;
}

std::string IndexJson(const ViewerIndex& index, bool packed) {
  core::Json cameras = core::Json::array();
  for (const CameraFrustum& f : index.cameras) {
    cameras.push_back({{"id", f.id},
                       {"width_px", f.width_px},
                       {"height_px", f.height_px},
                       {"centre_mm", Point(f.centre_mm)},
                       {"corners_mm",
                        {Point(f.corners_mm[0]), Point(f.corners_mm[1]), Point(f.corners_mm[2]),
                         Point(f.corners_mm[3])}}});
  }
  core::Json instants = core::Json::array();
  for (const InstantEntry& e : index.instants) {
    const bool truth = !e.truth_mesh.empty();
    auto error_url = [&](const std::string& mesh, MeshVariant v) {
      return truth && !mesh.empty()
                 ? core::Json("derived/error/" + e.name + "/" + VariantName(v) + ".f32")
                 : core::Json();
    };
    core::Json files = core::Json::array();
    for (size_t c = 0; c < e.cameras.size(); ++c) {
      const CameraFiles& f = e.cameras[c];
      core::Json depth;
      if (!f.depth_preview.empty())
        depth = "out/" + f.depth_preview;
      else if (!f.depth_map.empty())
        depth = "derived/depth/" + e.name + "/" + index.cameras[c].id + ".png";
      const std::string& id = index.cameras[c].id;
      files.push_back({{"image", Url("take/", f.image)},
                       {"depth", depth},
                       {"depth_source", f.depth_source},
                       {"mask", f.mask ? core::Json("derived/mask/" + e.name + "/" + id + ".png")
                                       : core::Json()},
                       {"mask_source", index.mask_sources[c]}});
    }
    instants.push_back({{"name", e.name},
                        {"label", e.label},
                        {"fused", Url("out/", e.fused)},
                        {"decimated", Url("out/", e.decimated)},
                        {"textured_glb", Url("out/", e.textured_glb)},
                        {"textured_obj", Url("out/", e.textured_obj)},
                        {"textured_png", Url("out/", e.textured_png)},
                        {"error",
                         {{"fused", error_url(e.fused, MeshVariant::kFused)},
                          {"decimated", error_url(e.decimated, MeshVariant::kDecimated)}}},
                        {"cameras", std::move(files)}});
  }
  core::Json j = {{"format", 1},
                        {"title", index.out_dir.filename().string()},
                        {"packed", packed},
                        {"error_range_mm", index.options.error_range_mm},
                        {"play_rate_hz", index.options.play_rate_hz},
                        {"cameras", std::move(cameras)},
                        {"instants", std::move(instants)},
                        {"masks_unavailable", index.masks_unavailable}};
  // A packed export is opened from file://, where the page cannot fetch (a 4D file is
  // read as a stream): its 4D files are not offered.
  j["sequences"] = core::Json::array();
  if (!packed)
    for (const std::string& s : index.sequences) j["sequences"].push_back("out/" + s);
  return core::DumpJson(j);
}

}  // namespace dome::view
