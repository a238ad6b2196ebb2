// `dome fuse TAKE --out OUT`: range images of each instant -> fused volume (in slabs)
// -> streamed marching cubes -> decimation -> texture (fusion/integrate.h,
// mesh/marching_cubes.h, mesh/decimate.h, mesh/texture.h). Until stereo depth exists the
// input is the take's truth depth with optional noise (--noise-mm); --depth-dir takes
// stereo output (DIR/<instant>/<camera>.tiff).
//   OUT/<instant>/mesh.ply             marching cubes (Taubin-smoothed with
//                                      --smooth-iterations), binary PLY, world mm
//   OUT/<instant>/mesh_decimated.ply   quadric decimation, per-vertex colour
//   OUT/<instant>/textured.obj/.mtl/.png  with --texture
//   OUT/<instant>/textured.glb         with --texture --glb (else mesh_decimated.glb,
//                                      vertex colours, with --glb)
//   OUT/<instant>/preview_<camera>.png with --preview CAMERA: the decimated, coloured
//                                      mesh ray cast from that rig camera (mesh/preview.h)
// With --eval and a truth mesh: accuracy/completeness against truth/<instant>/mesh.ply
// cropped to the box x, y in [-1500, 1500] mm, z in [30, 2600] mm (the batter, no floor)
// (eval/cloud_eval.h) and, for the synthetic dome, how much of the bat is recovered.
// One JSON line per instant on stdout.
//
// `dome mesh decimate IN OUT`, `dome mesh texture TAKE INSTANT IN OUT.obj|.glb`,
// `dome mesh preview TAKE IN.ply OUT.png --preview CAMERA`.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "core/error.h"
#include "core/timer.h"
#include "eval/cloud_eval.h"
#include "fusion/integrate.h"
#include "fusion/take_inputs.h"
#include "io/file_util.h"
#include "io/image_io.h"
#include "io/ply.h"
#include "mesh/decimate.h"
#include "mesh/gltf.h"
#include "mesh/marching_cubes.h"
#include "mesh/preview.h"
#include "mesh/smooth.h"
#include "mesh/texture.h"
#include "synth/batter.h"
#include "synth/synth.h"
#include "take/take.h"
#include "take/timecode.h"

namespace dome::cli {
namespace {

const geometry::TsaiCamera& FindCamera(const take::Take& take, const std::string& id) {
  for (const auto& rc : take.rig.cameras) {
    if (rc.model.id == id) return rc.model;
  }
  std::string ids;
  for (const auto& rc : take.rig.cameras) ids += (ids.empty() ? "" : ", ") + rc.model.id;
  throw core::InputError("--preview", "no camera '" + id + "' in the rig (cameras: " + ids + ")");
}

std::string Num(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

// The synthetic bat's barrel in the truth mesh: the truth triangles whose vertices are
// all within the bat's radius + 25 mm of its axis, from 250 mm past the knob (clear of
// the hands) to the end; the axis comes from the batter's pose at `time_s`
// (synth/batter.h).
io::Mesh BatBarrel(const io::Mesh& truth, double time_s) {
  const synth::BatterPose pose = synth::PoseBatter(time_s);
  const Eigen::Vector3d d = pose.bat_dir.normalized();
  auto on_barrel = [&](int v) {
    const Eigen::Vector3d p = truth.vertices[v].cast<double>() - pose.bat_knob_mm;
    const double s = p.dot(d);
    return s >= 250.0 && s <= pose.bat_length_mm + 25.0 &&
           (p - s * d).norm() <= pose.bat_radius_mm + 25.0;
  };
  io::Mesh barrel;
  std::vector<int> remap(truth.vertices.size(), -1);
  for (const auto& f : truth.faces) {
    if (!on_barrel(f[0]) || !on_barrel(f[1]) || !on_barrel(f[2])) continue;
    Eigen::Vector3i g;
    for (int k = 0; k < 3; ++k) {
      if (remap[f[k]] < 0) {
        remap[f[k]] = int(barrel.vertices.size());
        barrel.vertices.push_back(truth.vertices[f[k]]);
      }
      g[k] = remap[f[k]];
    }
    barrel.faces.push_back(g);
  }
  return barrel;
}

// The faces of `m` with every vertex inside [lo, hi] (vertices compacted).
io::Mesh Crop(const io::Mesh& m, const Eigen::Vector3f& lo, const Eigen::Vector3f& hi) {
  io::Mesh out;
  std::vector<int> remap(m.vertices.size(), -1);
  auto in = [&](int v) {
    return (m.vertices[v].array() >= lo.array()).all() &&
           (m.vertices[v].array() <= hi.array()).all();
  };
  for (const auto& f : m.faces) {
    if (!in(f[0]) || !in(f[1]) || !in(f[2])) continue;
    Eigen::Vector3i g;
    for (int k = 0; k < 3; ++k) {
      if (remap[f[k]] < 0) {
        remap[f[k]] = int(out.vertices.size());
        out.vertices.push_back(m.vertices[f[k]]);
      }
      g[k] = remap[f[k]];
    }
    out.faces.push_back(g);
  }
  return out;
}

}  // namespace

void AddFuseCommand(CLI::App* app, int* exit_code) {
  auto* cmd = app->add_subcommand(
      "fuse",
      "Fuse each instant's depth maps into a mesh (volumetric fusion, marching cubes, "
      "decimation, texture)");
  struct Args {
    std::string take, out, depth_dir;
    std::vector<std::string> depth_subdirs;
    std::vector<std::string> instants;
    double noise_mm = 0.0, voxel_mm = 20.0, decimate_ratio = 0.1;
    std::vector<double> origin, dims;
    uint64_t seed = 1;
    int slab_planes = 16;
    bool texture = false, evaluate = false, glb = false;
    std::string preview;
    fusion::FusionOptions fusion;
    mesh::SmoothOptions smooth;
  };
  auto a = std::make_shared<Args>();
  cmd->add_option("TAKE", a->take, "take folder")->required();
  cmd->add_option("--out", a->out, "output folder")->required();
  cmd->add_option("--instant", a->instants, "instants to fuse (default: all)");
  cmd->add_option("--depth-dir", a->depth_dir,
                  "stereo depth (dome stereo --out DIR): DIR/<instant>/depth/<camera>.tiff, or "
                  "DIR/<instant>/<camera>.tiff (default: the take's truth depth)");
  cmd->add_option("--depth-subdir", a->depth_subdirs,
                  "with --depth-dir: the window folders to fuse, each map its own input (seed "
                  "§5), e.g. --depth-subdir depth --depth-subdir depth-w13 (default: depth)");
  cmd->add_option("--noise-mm", a->noise_mm, "Gaussian noise added to truth depth, mm")
      ->capture_default_str();
  cmd->add_option("--seed", a->seed, "noise seed")->capture_default_str();
  cmd->add_option("--voxel-mm", a->voxel_mm, "voxel edge, mm (seed: 20)")->capture_default_str();
  cmd->add_option("--origin", a->origin,
                  "volume min corner x y z, mm (default: the seed's 6 m "
                  "cube around the dome, -3000 -3000 -2750)")
      ->expected(3);
  cmd->add_option("--dims", a->dims, "voxels along x y z (default: 6000 mm / voxel)")->expected(3);
  cmd->add_option("--slab-planes", a->slab_planes, "voxel planes per slab")->capture_default_str();
  cmd->add_option("--threads", a->fusion.num_threads, "threads (0: all)");
  cmd->add_option("--truncation-mm", a->fusion.truncation_mm,
                  "untouched beyond this far behind the surface, mm (default 3 voxels)");
  cmd->add_option("--clamp-mm", a->fusion.front_clamp_mm,
                  "free-space contribution clamp, mm (default 3 voxels)");
  cmd->add_option("--jump-ratio", a->fusion.max_depth_jump_ratio,
                  "depth jump (fraction of depth) that breaks the tessellation")
      ->capture_default_str();
  cmd->add_option("--consistent-views", a->fusion.min_consistent_views,
                  "fuse a depth sample only if this many other cameras agree (0: off)")
      ->capture_default_str();
  cmd->add_option("--consistency-mm", a->fusion.consistency_tolerance_mm,
                  "largest depth difference that agrees, mm (default 1 voxel)");
  cmd->add_option("--min-weight", a->fusion.min_weight,
                  "voxels of less summed weight (images) are left unobserved (0: keep all)")
      ->capture_default_str();
  cmd->add_option("--smooth-iterations", a->smooth.iterations,
                  "Taubin smoothing of mesh.ply, lambda|mu pairs (0: none; mesh/smooth.h)")
      ->capture_default_str();
  cmd->add_option("--decimate-ratio", a->decimate_ratio, "decimation target, fraction of triangles")
      ->capture_default_str();
  cmd->add_flag("--texture", a->texture, "also write a textured OBJ (atlas)");
  cmd->add_flag("--glb", a->glb, "also write binary glTF (textured with --texture)");
  cmd->add_option("--preview", a->preview,
                  "rig camera id: write preview_<camera>.png of the decimated mesh");
  cmd->add_flag("--eval", a->evaluate, "evaluate against truth/<instant>/mesh.ply");
  auto* truncation = cmd->get_option("--truncation-mm");
  auto* clamp = cmd->get_option("--clamp-mm");
  cmd->callback([=] {
    try {
      a->smooth.Check();
    } catch (const core::InputError& e) {
      throw e.Under("--smooth-iterations");
    }
    const take::Take take = take::OpenTake(a->take);
    fusion::VolumeGrid grid;
    grid.voxel_size_mm = a->voxel_mm;
    core::Require(a->voxel_mm > 0, "--voxel-mm", "must be positive");
    grid.nx = grid.ny = grid.nz = int(std::lround(6000.0 / a->voxel_mm));
    if (!a->origin.empty())
      grid.origin_mm = Eigen::Vector3d(a->origin[0], a->origin[1], a->origin[2]);
    if (!a->dims.empty()) {
      grid.nx = int(a->dims[0]);
      grid.ny = int(a->dims[1]);
      grid.nz = int(a->dims[2]);
    }
    grid.Check("--voxel-mm/--origin/--dims");
    fusion::FusionOptions options = a->fusion;
    if (truncation->count() == 0) options.truncation_mm = 3 * a->voxel_mm;
    if (clamp->count() == 0) options.front_clamp_mm = 3 * a->voxel_mm;
    if (cmd->count("--consistency-mm") == 0) options.consistency_tolerance_mm = a->voxel_mm;
    options.Check();
    core::Require(a->slab_planes > 0, "--slab-planes", "must be positive");
    if (!a->preview.empty()) FindCamera(take, a->preview);  // fail before any work
    std::vector<std::string> instants = a->instants.empty() ? take.instants : a->instants;
    for (const std::string& instant : instants) {
      const auto pos = std::find(take.instants.begin(), take.instants.end(), instant);
      core::Require(pos != take.instants.end(), "--instant",
                    "no instant '" + instant + "' in the take");
      const std::filesystem::path dir = std::filesystem::path(a->out) / instant;
      std::filesystem::create_directories(dir);
      core::Stopwatch total;
      std::vector<fusion::RangeImage> images;
      if (a->depth_dir.empty()) {
        fusion::TruthDepthOptions truth;
        truth.noise_sigma_mm = a->noise_mm;
        truth.seed = a->seed;
        images = fusion::LoadTruthRangeImages(take, instant, truth);
      } else {
        const std::filesystem::path base = std::filesystem::path(a->depth_dir) / instant;
        const std::vector<std::string> subdirs =
            a->depth_subdirs.empty() ? std::vector<std::string>{"depth"} : a->depth_subdirs;
        for (const std::string& sub : subdirs) {
          // The stereo layout, or the flat one for the default.
          const bool flat = a->depth_subdirs.empty() && !std::filesystem::is_directory(base / sub);
          auto more = fusion::LoadRangeImagesFromDir(take, flat ? base : base / sub);
          for (auto& im : more) images.push_back(std::move(im));
        }
      }
      const double t_load = total.ElapsedSeconds();
      core::Stopwatch w;
      fusion::Integrator integrator(grid, images, options);
      mesh::StreamingMarchingCubes mc(grid);
      double t_fusion = w.ElapsedSeconds(), t_mc = 0;
      fusion::Slab slab;  // reused from slab to slab
      for (int k0 = 0; k0 < grid.nz; k0 += a->slab_planes) {
        w.Restart();
        integrator.IntegrateSlab(k0, std::min(grid.nz, k0 + a->slab_planes), &slab);
        t_fusion += w.ElapsedSeconds();
        w.Restart();
        mc.AddSlab(slab);
        t_mc += w.ElapsedSeconds();
      }
      io::Mesh surface = mc.Finish();
      w.Restart();
      mesh::SmoothTaubin(a->smooth, &surface);
      t_mc += w.ElapsedSeconds();
      io::WritePly(dir / "mesh.ply", surface, {io::PlyFormat::kBinaryLittleEndian, {"units mm"}});
      w.Restart();
      mesh::DecimationOptions dec;
      dec.target_ratio = a->decimate_ratio;
      io::Mesh decimated = mesh::Decimate(surface, dec);
      const double t_dec = w.ElapsedSeconds();
      w.Restart();
      const auto views = mesh::LoadTextureViews(take, instant);
      mesh::TextureOptions tex;
      tex.num_threads = options.num_threads;
      mesh::ColorVertices(&decimated, views, tex);
      if (a->texture) {
        const mesh::TexturedMesh textured = mesh::BuildTextureAtlas(decimated, views, tex);
        mesh::WriteTexturedObj(dir / "textured.obj", textured);
        if (a->glb) mesh::WriteGlb(dir / "textured.glb", textured);
      } else if (a->glb) {
        mesh::WriteGlb(dir / "mesh_decimated.glb", decimated);
      }
      const double t_tex = w.ElapsedSeconds();
      double t_preview = 0;
      if (!a->preview.empty()) {
        w.Restart();
        mesh::PreviewOptions po;
        po.num_threads = options.num_threads;
        io::WriteImage(dir / ("preview_" + a->preview + ".png"),
                       mesh::RenderPreview(decimated, FindCamera(take, a->preview), po));
        t_preview = w.ElapsedSeconds();
      }
      io::WritePly(dir / "mesh_decimated.ply", decimated,
                   {io::PlyFormat::kBinaryLittleEndian, {"units mm"}});
      std::string json =
          "{\"instant\": \"" + instant + "\", \"cameras\": " + std::to_string(images.size()) +
          ", \"voxel_mm\": " + Num(grid.voxel_size_mm) + ", \"voxels\": [" +
          std::to_string(grid.nx) + ", " + std::to_string(grid.ny) + ", " +
          std::to_string(grid.nz) + "], \"triangles\": " + std::to_string(surface.faces.size()) +
          ", \"decimated_triangles\": " + std::to_string(decimated.faces.size()) +
          ", \"seconds\": {\"load\": " + Num(t_load) + ", \"fusion\": " + Num(t_fusion) +
          ", \"marching_cubes\": " + Num(t_mc) + ", \"decimation\": " + Num(t_dec) +
          ", \"texture\": " + Num(t_tex) + ", \"preview\": " + Num(t_preview) +
          ", \"total\": " + Num(total.ElapsedSeconds()) + "}";
      const auto truth_mesh = take.TruthMeshPath(instant);
      if (a->evaluate && std::filesystem::exists(truth_mesh)) {
        eval::CloudEvalOptions eo;
        eo.thresholds_mm = {5, 10, 20, 40};
        eo.reference_mesh_use = eval::ReferenceMeshUse::kSurface;
        eo.mesh_sample_density_per_mm2 = 0.01;
        eo.reference_sample_density_per_mm2 = 0.01;
        eo.num_threads = options.num_threads;
        // The scene inside the volume above the floor: the person and the bat (the
        // room's walls lie outside the seed's 6 m cube, the floor is trivially exact).
        const Eigen::Vector3f lo = (grid.origin_mm + Eigen::Vector3d(0, 0, 0))
                                       .cast<float>()
                                       .cwiseMax(Eigen::Vector3f(-1500, -1500, 30));
        const Eigen::Vector3f hi =
            (grid.origin_mm + grid.voxel_size_mm * Eigen::Vector3d(grid.nx, grid.ny, grid.nz))
                .cast<float>()
                .cwiseMin(Eigen::Vector3f(1500, 1500, 2600));
        const io::Mesh reference = Crop(io::ReadPly(truth_mesh), lo, hi);
        eo.box_margin = 0.0;
        const auto r = eval::EvaluateReconstruction(surface, reference, eo);
        json += ", \"vs_truth_person_box\": " + eval::ToJson(r);
        // The bat: how much of its barrel's truth surface the mesh recovers.
        const double t_s = synth::InstantTimeS(int(pos - take.instants.begin()));
        const io::Mesh barrel = BatBarrel(io::ReadPly(truth_mesh), t_s);
        if (!barrel.faces.empty()) {
          eval::CloudEvalOptions bo = eo;
          bo.reference_mesh_use = eval::ReferenceMeshUse::kSurface;
          bo.reference_sample_density_per_mm2 = 0.05;
          const auto bat = eval::EvaluateReconstruction(surface, barrel, bo);
          json += ", \"bat_barrel\": {\"truth_samples\": " + std::to_string(bat.n_ref_pts) +
                  ", \"completeness@5mm\": " + Num(bat.scores[0].completeness) +
                  ", \"completeness@10mm\": " + Num(bat.scores[1].completeness) +
                  ", \"completeness@20mm\": " + Num(bat.scores[2].completeness) +
                  ", \"comp_median_mm\": " + Num(bat.comp_median_mm) +
                  ", \"precision@10mm_in_bat_box\": " + Num(bat.scores[1].precision) + "}";
        }
      }
      std::printf("%s}\n", json.c_str());
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
    const std::clock_t cpu0 = std::clock();  // decimation is single-threaded
    const io::Mesh out = mesh::Decimate(in, o, &s);
    const double cpu = double(std::clock() - cpu0) / CLOCKS_PER_SEC;
    w.Restart();
    io::WritePly(d->out, out);
    const double t_write = w.ElapsedSeconds();
    std::printf(
        "{\"triangles_in\": %lld, \"triangles_out\": %lld, \"components_removed\": %lld, "
        "\"triangles_removed\": %lld, \"components_deleted\": %lld, \"triangles_deleted\": "
        "%lld, \"error_mm\": %s, \"seconds\": %s, \"cpu_seconds\": %s, \"read_seconds\": "
        "%s, \"write_seconds\": %s}\n",
        (long long)s.triangles_in, (long long)s.triangles_out, (long long)s.components_removed,
        (long long)s.triangles_removed, (long long)s.components_deleted,
        (long long)s.triangles_deleted, Num(s.error_mm).c_str(), Num(s.seconds).c_str(),
        Num(cpu).c_str(), Num(t_read).c_str(), Num(t_write).c_str());
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
    io::Mesh m = io::ReadPly(t->in);
    const auto views = mesh::LoadTextureViews(take, t->instant);
    const mesh::TexturedMesh textured = mesh::BuildTextureAtlas(m, views, t->options);
    if (std::filesystem::path(t->out).extension() == ".glb") {
      mesh::WriteGlb(t->out, textured);
    } else {
      mesh::WriteTexturedObj(t->out, textured);
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
