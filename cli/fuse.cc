// `dome fuse TAKE --out OUT`: each instant's range images through the pipeline's stage
// functions (pipeline/stages.h) in this process: fusion slab by slab into the streamed
// surface, decimation, texture; the options resolve as a session's do
// (pipeline/session.h), so that `dome fuse` and `dome run` give the same bytes. The input
// is the take's truth depth with optional noise (--noise-mm), or stereo output
// (--depth-dir DIR: DIR/<instant>/depth/<camera>.tiff or DIR/<instant>/<camera>.tiff).
//   OUT/<instant>/mesh.ply             the surface (Taubin-smoothed with
//                                      --smooth-iterations), binary PLY, world mm
//   OUT/<instant>/mesh_decimated.ply   decimated, per-vertex colour
//   OUT/<instant>/textured.obj/.mtl/.png/.glb  with --texture
//   OUT/<instant>/mesh_decimated.glb   with --glb and no --texture (vertex colours)
//   OUT/<instant>/preview_<camera>.png with --preview CAMERA: the decimated, coloured
//                                      mesh ray cast from that rig camera (mesh/preview.h)
// One JSON line per instant on stdout: sizes and seconds per stage.
//
// `dome mesh decimate IN OUT`, `dome mesh texture TAKE INSTANT IN OUT.obj|.glb`,
// `dome mesh preview TAKE IN.ply OUT.png --preview CAMERA`.
#include <algorithm>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "cli/setting_flags.h"
#include "core/error.h"
#include "core/timer.h"
#include "fusion/take_inputs.h"
#include "io/file_util.h"
#include "io/image_io.h"
#include "io/ply.h"
#include "mesh/gltf.h"
#include "mesh/preview.h"
#include "pipeline/defaults.h"
#include "pipeline/session.h"
#include "pipeline/stages.h"
#include "take/take.h"

namespace dome::cli {
namespace {

namespace fs = std::filesystem;

const geometry::TsaiCamera& FindCamera(const take::Take& take, const std::string& id) {
  const int k = take.rig.Find(id);
  if (k >= 0) return take.rig.cameras[k].model;
  std::string ids;
  for (const auto& rc : take.rig.cameras) ids += (ids.empty() ? "" : ", ") + rc.model.id;
  throw core::InputError("--preview", "no camera '" + id + "' in the rig (cameras: " + ids + ")");
}

// The range images of one instant: stereo output under `depth_dir` (the window folders
// `subdirs`, each map its own input, seed §5), else the take's truth depth.
std::vector<fusion::RangeImage> LoadRangeImages(const take::Take& take, const std::string& instant,
                                                const std::string& depth_dir,
                                                const std::vector<std::string>& subdirs,
                                                const fusion::TruthDepthOptions& truth) {
  if (depth_dir.empty()) return fusion::LoadTruthRangeImages(take, instant, truth);
  std::vector<fusion::RangeImage> images;
  const fs::path base = fs::path(depth_dir) / instant;
  for (const std::string& sub : subdirs.empty() ? std::vector<std::string>{"depth"} : subdirs) {
    // The stereo layout, or the flat one for the default.
    const bool flat = subdirs.empty() && !fs::is_directory(base / sub);
    for (auto& im : fusion::LoadRangeImagesFromDir(take, flat ? base : base / sub)) {
      images.push_back(std::move(im));
    }
  }
  return images;
}

}  // namespace

void AddFuseCommand(CLI::App* app, int* exit_code) {
  auto* cmd = app->add_subcommand(
      "fuse",
      "Fuse each instant's depth maps into a mesh (volumetric fusion, marching cubes, "
      "decimation, texture)");
  struct Args {
    std::string take, out, depth_dir, preview;
    std::vector<std::string> depth_subdirs, instants;
    fusion::TruthDepthOptions truth;
    double voxel_mm = 0, decimate_ratio = 0;
    std::vector<double> origin;
    std::vector<int> dims;
    int slab_planes = 0, smooth_iterations = 0, threads = 0;
    bool texture = false, glb = false;
  };
  auto a = std::make_shared<Args>();
  a->truth.noise_sigma_mm = 0;
  cmd->add_option("TAKE", a->take, "take folder")->required();
  cmd->add_option("--out", a->out, "output folder")->required();
  cmd->add_option("--instant", a->instants, "instants to fuse (default: all)");
  cmd->add_option("--depth-dir", a->depth_dir,
                  "stereo depth (dome stereo --out DIR): DIR/<instant>/depth/<camera>.tiff, or "
                  "DIR/<instant>/<camera>.tiff (default: the take's truth depth)");
  cmd->add_option("--depth-subdir", a->depth_subdirs,
                  "with --depth-dir: the window folders to fuse, each map its own input (seed "
                  "§5), e.g. --depth-subdir depth --depth-subdir depth-w13 (default: depth)");
  cmd->add_option("--noise-mm", a->truth.noise_sigma_mm, "Gaussian noise added to truth depth, mm")
      ->capture_default_str();
  cmd->add_option("--seed", a->truth.seed, "noise seed")->capture_default_str();
  auto* voxel = cmd->add_option("--voxel-mm", a->voxel_mm, "voxel edge, mm (seed: 20)");
  auto* origin = cmd->add_option("--origin", a->origin,
                                 "volume min corner x y z, mm (default: the seed's 6 m cube "
                                 "around the dome, -3000 -3000 -2750)")
                     ->expected(3);
  auto* dims = cmd->add_option("--dims", a->dims, "voxels along x y z (default: 6000 mm / voxel)")
                   ->expected(3);
  auto* slabs = cmd->add_option("--slab-planes", a->slab_planes, "voxel planes per slab (16)");
  cmd->add_option("--threads", a->threads, "threads (0: all)");
  auto fusion_flags = std::make_shared<SettingFlags<fusion::FusionOptions>>(
      cmd, pipeline::FusionSettingFields(),
      pipeline::DefaultFusionOptions(pipeline::kDefaultVoxelMm));
  auto* smooth = cmd->add_option("--smooth-iterations", a->smooth_iterations,
                                 "Taubin smoothing of mesh.ply, lambda|mu pairs (0: none; "
                                 "mesh/smooth.h)");
  auto* ratio = cmd->add_option("--decimate-ratio", a->decimate_ratio,
                                "decimation target, fraction of triangles (0.1)");
  cmd->add_flag("--texture", a->texture, "also write a textured OBJ and glTF (atlas)");
  cmd->add_flag("--glb", a->glb, "also write binary glTF (textured with --texture)");
  cmd->add_option("--preview", a->preview,
                  "rig camera id: write preview_<camera>.png of the decimated mesh");
  cmd->callback([=] {
    // The options as a session holds them: the same defaults and checks as dome run's.
    runtime::Session session;
    if (voxel->count()) session.mutable_volume()->set_voxel_size_mm(a->voxel_mm);
    for (double v : origin->count() ? a->origin : std::vector<double>{})
      session.mutable_volume()->add_origin_mm(v);
    for (int v : dims->count() ? a->dims : std::vector<int>{})
      session.mutable_volume()->add_dims(v);
    fusion_flags->Apply(session.mutable_fusion());
    if (slabs->count()) session.set_slab_planes(a->slab_planes);
    if (smooth->count()) session.set_smooth_iterations(a->smooth_iterations);
    if (ratio->count()) session.set_decimate_ratio(a->decimate_ratio);
    const pipeline::SessionOptions o = pipeline::ResolveSessionOptions(session, "fuse");
    const take::Take take = take::OpenTake(a->take);
    if (!a->preview.empty()) FindCamera(take, a->preview);  // fail before any work
    for (const std::string& instant : a->instants.empty() ? take.instants : a->instants) {
      core::Require(
          std::find(take.instants.begin(), take.instants.end(), instant) != take.instants.end(),
          "--instant", "no instant '" + instant + "' in the take");
      const fs::path dir = fs::path(a->out) / instant;
      fs::create_directories(dir);
      core::Stopwatch total, w;
      auto images = LoadRangeImages(take, instant, a->depth_dir, a->depth_subdirs, a->truth);
      const size_t cameras = images.size();
      const double t_load = total.ElapsedSeconds();
      fusion::FusionOptions fo = o.fusion;
      fo.num_threads = a->threads;
      w.Restart();
      auto prepared = pipeline::PrepareFusion(o.grid, std::move(images), fo);
      double t_fusion = w.ElapsedSeconds();
      const double t_setup = t_fusion;
      w.Restart();
      const int num_slabs = pipeline::SlabCount(o.grid, o.slab_planes);
      fusion::Slab buffer;  // each slab's, reused
      const io::Mesh surface = pipeline::Surface(
          o.grid, num_slabs,
          [&](int s) {
            core::Stopwatch f;
            const auto [k0, k1] = pipeline::SlabPlanes(o.grid, o.slab_planes, s);
            const fusion::Slab& slab = pipeline::FuseSlab(*prepared, &buffer, k0, k1);
            t_fusion += f.ElapsedSeconds();
            return std::shared_ptr<const fusion::Slab>(&slab, [](const fusion::Slab*) {});
          },
          o.smooth);
      const double t_mc = w.ElapsedSeconds() - (t_fusion - t_setup);  // the slabs' own time
      io::WriteFileAtomically(dir / pipeline::kMeshPly, pipeline::EncodeMeshPly(surface));
      w.Restart();
      mesh::DecimationSummary dec_summary;
      io::Mesh decimated = pipeline::Decimate(surface, pipeline::DecimationFor(o), &dec_summary);
      const double t_dec = w.ElapsedSeconds();
      w.Restart();
      mesh::TextureOptions tex;
      tex.num_threads = a->threads;
      pipeline::TextureResult textured = pipeline::Texture(
          std::move(decimated), mesh::LoadTextureViews(take, instant), tex, a->texture);
      if (textured.atlas) {
        for (const auto& f : pipeline::TexturedFiles(*textured.atlas, a->threads)) {
          if (a->glb || f.name != pipeline::kTexturedGlb)
            io::WriteFileAtomically(dir / f.name, f.bytes);
        }
      } else if (a->glb) {
        mesh::WriteGlb(dir / "mesh_decimated.glb", textured.coloured);
      }
      const double t_tex = w.ElapsedSeconds();
      w.Restart();
      if (!a->preview.empty()) {
        mesh::PreviewOptions po;
        po.num_threads = a->threads;
        io::WriteImage(dir / ("preview_" + a->preview + ".png"),
                       mesh::RenderPreview(textured.coloured, FindCamera(take, a->preview), po));
      }
      const double t_preview = w.ElapsedSeconds();
      io::WriteFileAtomically(dir / pipeline::kDecimatedPly,
                              pipeline::EncodeMeshPly(textured.coloured));
      nlohmann::ordered_json line = {{"instant", instant},
                                     {"cameras", cameras},
                                     {"voxel_mm", o.grid.voxel_size_mm},
                                     {"voxels", {o.grid.nx, o.grid.ny, o.grid.nz}},
                                     {"triangles", surface.faces.size()},
                                     {"decimated_triangles", textured.coloured.faces.size()},
                                     {"specks_removed", dec_summary.specks_removed},
                                     {"speck_triangles", dec_summary.speck_triangles},
                                     {"seconds",
                                      {{"load", t_load},
                                       {"fusion", t_fusion},
                                       {"marching_cubes", t_mc},
                                       {"decimation", t_dec},
                                       {"texture", t_tex},
                                       {"preview", t_preview},
                                       {"total", total.ElapsedSeconds()}}}};
      std::printf("%s\n", line.dump().c_str());
      std::fflush(stdout);
    }
    *exit_code = 0;
  });
}

void AddMeshCommand(CLI::App* app, int* exit_code) {
  auto* cmd = app->add_subcommand("mesh", "Mesh tools: decimate, texture, preview");
  cmd->require_subcommand(1);
  struct DecArgs {
    std::string in, out;
    mesh::DecimationOptions options;
    bool free_border = false, lock_border = false, meshoptimizer = false;
  };
  auto d = std::make_shared<DecArgs>();
  auto* dec = cmd->add_subcommand("decimate", "Quadric-error decimation of a PLY mesh");
  dec->add_option("IN", d->in, "input mesh, PLY")->required();
  dec->add_option("OUT", d->out, "output mesh, PLY (binary)")->required();
  dec->add_option("--ratio", d->options.target_ratio, "target fraction of triangles")
      ->capture_default_str();
  dec->add_option("--triangles", d->options.target_triangles,
                  "target triangle count (overrides --ratio)");
  dec->add_option("--max-error-mm", d->options.max_error_mm,
                  "stop before moving the surface more, mm");
  dec->add_flag("--free-border", d->free_border, "let open borders move (the default)");
  dec->add_flag("--lock-border", d->lock_border, "keep open-border vertices in place");
  dec->add_option("--border-weight", d->options.border_weight,
                  "weight of the planes holding free borders (times edge length squared)")
      ->capture_default_str();
  dec->add_flag("!--no-relocate", d->options.relocate_vertices,
                "meshoptimizer: keep surviving vertices where the simplifier left them");
  dec->add_option("--min-component-triangles", d->options.min_component_triangles,
                  "drop connected parts with fewer triangles first")
      ->capture_default_str();
  dec->add_option("--min-component-mm", d->options.min_component_diagonal_mm,
                  "drop connected parts with a smaller bounding-box diagonal first, mm")
      ->capture_default_str();
  dec->add_option("--component-deletion", d->options.component_deletion_factor,
                  "delete whole connected parts (not the largest) when cheaper than the next "
                  "collapse, as if moving their area this factor times the geometric mean of "
                  "their diagonal and their distance to the largest part; 0 = never")
      ->capture_default_str();
  dec->add_option("--deviation-weight", d->options.deviation_weight,
                  "add this times the merged area times the squared distance of the new faces "
                  "to the faces they replace to a collapse's cost; 0 = quadric only")
      ->capture_default_str();
  dec->add_option("--deviation-from", d->options.deviation_from_factor,
                  "count the deviation only once the faces are within this factor of the "
                  "target (the quadric alone before); 0 = from the first collapse")
      ->capture_default_str();
  dec->add_option("--speck-area-fraction", d->options.speck_area_fraction,
                  "drop parts with less than this fraction of the largest part's area and a "
                  "diagonal under --speck-mm first; 0 = none")
      ->capture_default_str();
  dec->add_option("--speck-mm", d->options.speck_diagonal_mm,
                  "the speck rule's bounding-box diagonal, mm; 0 = none")
      ->capture_default_str();
  dec->add_option("--speck-gap-mm", d->options.speck_gap_mm,
                  "keep a small part that comes this near a part that is not small, mm; 0 = "
                  "drop small parts wherever they are")
      ->capture_default_str();
  dec->add_option("--prepass", d->options.prepass_factor,
                  "meshoptimizer first, to this times the target, the input's quadrics carried "
                  "to its vertices; then edge collapse; 0 = edge collapse only")
      ->capture_default_str();
  dec->add_option("--threads", d->options.num_threads,
                  "threads for the regions of a large mesh (the output is the same for any); "
                  "0 = all hardware threads")
      ->capture_default_str();
  dec->add_option("--faces-per-region", d->options.faces_per_region,
                  "decimate a large mesh in regions of at least this many faces, in parallel, "
                  "then joined; 0 = one region")
      ->capture_default_str();
  dec->add_flag("--meshoptimizer", d->meshoptimizer,
                "meshoptimizer's topology-preserving simplifier instead of edge collapse");
  dec->callback([=] {
    mesh::DecimationOptions o = d->options;
    o.lock_border = d->lock_border && !d->free_border;
    if (d->meshoptimizer) o.method = mesh::DecimationMethod::kMeshoptimizer;
    mesh::DecimationSummary s;
    core::Stopwatch w;
    const io::Mesh in = io::ReadPly(d->in);
    const double t_read = w.ElapsedSeconds();
    const std::clock_t cpu0 = std::clock();  // the process's: all its threads
    const io::Mesh out = pipeline::Decimate(in, o, &s);
    const double cpu = double(std::clock() - cpu0) / CLOCKS_PER_SEC;
    w.Restart();
    io::WritePly(d->out, out);
    nlohmann::ordered_json line = nlohmann::ordered_json::parse(pipeline::DecimationSummaryJson(s));
    line["cpu_seconds"] = cpu;
    line["read_seconds"] = t_read;
    line["write_seconds"] = w.ElapsedSeconds();
    std::printf("%s\n", line.dump().c_str());
    *exit_code = 0;
  });
  struct TexArgs {
    std::string take, instant, in, out;
    mesh::TextureOptions options;
  };
  auto t = std::make_shared<TexArgs>();
  auto* tex =
      cmd->add_subcommand("texture", "Texture a mesh from an instant's images (OBJ+MTL+PNG)");
  tex->add_option("TAKE", t->take, "take folder")->required();
  tex->add_option("INSTANT", t->instant, "instant HH-MM-SS-FF")->required();
  tex->add_option("IN", t->in, "mesh, PLY (world mm)")->required();
  tex->add_option("OUT", t->out,
                  "textured mesh .obj (the .mtl and .png go beside it) or .glb (one file)")
      ->required();
  tex->add_option("--cell-px", t->options.atlas_cell_px, "atlas cell edge, texels")
      ->capture_default_str();
  tex->callback([=] {
    const take::Take take = take::OpenTake(t->take);
    const pipeline::TextureResult textured = pipeline::Texture(
        io::ReadPly(t->in), mesh::LoadTextureViews(take, t->instant), t->options, true);
    if (fs::path(t->out).extension() == ".glb") {
      mesh::WriteGlb(t->out, *textured.atlas);
    } else {
      mesh::WriteTexturedObj(t->out, *textured.atlas);
    }
    *exit_code = 0;
  });
  struct PreviewArgs {
    std::string take, in, out, camera;
    mesh::PreviewOptions options;
    bool grey = false;
  };
  auto pv = std::make_shared<PreviewArgs>();
  auto* preview = cmd->add_subcommand(
      "preview", "Ray-cast a PLY mesh from one rig camera into a PNG (vertex colours or grey)");
  preview->add_option("TAKE", pv->take, "take folder (for the rig)")->required();
  preview->add_option("IN", pv->in, "mesh, PLY (world mm)")->required();
  preview->add_option("OUT", pv->out, "preview image, PNG")->required();
  preview->add_option("--preview", pv->camera, "rig camera id")->required();
  preview->add_flag("--grey", pv->grey, "grey shading even when the mesh has colours");
  preview->add_option("--threads", pv->options.num_threads, "threads (0: all)");
  preview->callback([=] {
    const take::Take take = take::OpenTake(pv->take);
    const geometry::TsaiCamera& camera = FindCamera(take, pv->camera);
    mesh::PreviewOptions o = pv->options;
    o.use_colors = !pv->grey;
    io::WriteImage(pv->out, mesh::RenderPreview(io::ReadPly(pv->in), camera, o));
    *exit_code = 0;
  });
}

}  // namespace dome::cli
