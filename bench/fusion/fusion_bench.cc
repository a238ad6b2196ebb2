// Fusion benchmark on a take's instant (the seed's workload with the paper preset: 51
// depth maps of 320x245 into 300^3 voxels of 20 mm), stage by stage:
//   fusion (slabs of --slab-planes planes), streamed marching cubes, decimation to
//   10 %, per-vertex texture. Writes OUT/mesh.ply, OUT/mesh_decimated.ply and, for the
//   Open3D comparison (open3d_compare.py), the exact depth maps fused:
//   OUT/depth/<camera>.f32 (float32 row-major, mm) and OUT/cameras.json (pinhole K of
//   the undistorted camera, world->camera R and t in mm). Prints one JSON line;
//   fusion_s is wall time (best of --repeat), fusion_cpu_s the process CPU time of that
//   stage (all threads; a check on a machine shared with other work). Each repeat builds
//   a new integrator; from the second on it reuses the first one's table memory, as a
//   worker fusing instant after instant does (fusion/integrate.h).
//
//   With --fusion-only 1 it stops after fusion and marching cubes (no decimation,
//   texture or meshes written): a short run for timing fusion alone.
//
//   fusion_bench TAKE INSTANT OUT [--threads N] [--noise-mm S] [--voxel-mm V]
//                [--slab-planes P] [--repeat R] [--fusion-only 0|1]
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <string>

#include "core/parallel_for.h"
#include "core/timer.h"
#include "fusion/integrate.h"
#include "fusion/take_inputs.h"
#include "io/file_util.h"
#include "io/image_io.h"
#include "io/ply.h"
#include "mesh/decimate.h"
#include "mesh/marching_cubes.h"
#include "mesh/texture.h"

using namespace dome;

int main(int argc, char** argv) {
  if (argc < 4) {
    std::fprintf(stderr,
                 "usage: fusion_bench TAKE INSTANT OUT [--threads N] [--noise-mm S] "
                 "[--voxel-mm V] [--slab-planes P] [--repeat R] [--fusion-only 0|1]\n");
    return 2;
  }
  const std::filesystem::path out = argv[3];
  int threads = 2, slab_planes = 10, repeat = 3;
  bool fusion_only = false;
  double noise = 10.0, voxel = 20.0;
  for (int a = 4; a + 1 < argc; a += 2) {
    const std::string k = argv[a];
    if (k == "--threads")
      threads = std::atoi(argv[a + 1]);
    else if (k == "--noise-mm")
      noise = std::atof(argv[a + 1]);
    else if (k == "--voxel-mm")
      voxel = std::atof(argv[a + 1]);
    else if (k == "--slab-planes")
      slab_planes = std::atoi(argv[a + 1]);
    else if (k == "--repeat")
      repeat = std::atoi(argv[a + 1]);
    else if (k == "--fusion-only")
      fusion_only = std::atoi(argv[a + 1]) != 0;
  }
  try {
    const take::Take take = take::OpenTake(argv[1]);
    const std::string instant = argv[2];
    std::filesystem::create_directories(out / "depth");
    fusion::TruthDepthOptions truth;
    truth.noise_sigma_mm = noise;
    const auto images = fusion::LoadTruthRangeImages(take, instant, truth);
    std::string cams = "[";
    for (const auto& im : images) {
      io::WriteFileAtomically(out / "depth" / (im.camera.id + ".f32"),
                              std::string(reinterpret_cast<const char*>(im.depth_mm.ptr<float>(0)),
                                          im.depth_mm.total() * 4));
      const Eigen::Matrix3d K = im.camera.K();
      char buf[1024];
      std::snprintf(
          buf, sizeof buf,
          "%s{\"id\": \"%s\", \"width\": %d, \"height\": %d, \"fx\": %.17g, \"fy\": %.17g, "
          "\"cx\": %.17g, \"cy\": %.17g, \"R\": [%.17g, %.17g, %.17g, %.17g, %.17g, %.17g, "
          "%.17g, %.17g, %.17g], \"t\": [%.17g, %.17g, %.17g]}",
          cams.size() > 1 ? ", " : "", im.camera.id.c_str(), im.camera.width_px,
          im.camera.height_px, K(0, 0), K(1, 1), K(0, 2), K(1, 2), im.camera.rotation(0, 0),
          im.camera.rotation(0, 1), im.camera.rotation(0, 2), im.camera.rotation(1, 0),
          im.camera.rotation(1, 1), im.camera.rotation(1, 2), im.camera.rotation(2, 0),
          im.camera.rotation(2, 1), im.camera.rotation(2, 2), im.camera.translation_mm.x(),
          im.camera.translation_mm.y(), im.camera.translation_mm.z());
      cams += buf;
    }
    io::WriteFileAtomically(out / "cameras.json", cams + "]\n");

    fusion::VolumeGrid grid;  // the seed's 6 m cube
    grid.voxel_size_mm = voxel;
    grid.nx = grid.ny = grid.nz = int(std::lround(6000.0 / voxel));
    fusion::FusionOptions options;
    options.num_threads = threads;
    options.truncation_mm = options.front_clamp_mm = 3 * voxel;

    double best_fusion = 1e30, best_mc = 1e30, best_setup = 1e30, best_cpu = 1e30,
           best_setup_cpu = 1e30;
    io::Mesh mesh;
    fusion::Slab slab;  // reused: no allocation per slab
    for (int r = 0; r < std::max(1, repeat); ++r) {
      const std::clock_t cpu0 = std::clock();
      core::Stopwatch setup;
      fusion::Integrator integrator(grid, images, options);
      const double t_setup = setup.ElapsedSeconds();
      best_setup_cpu = std::min(best_setup_cpu, double(std::clock() - cpu0) / CLOCKS_PER_SEC);
      mesh::StreamingMarchingCubes mc(grid);
      double t_fusion = 0, t_mc = 0;
      std::clock_t cpu_mc = 0, cpu_mc0 = 0;
      for (int k0 = 0; k0 < grid.nz; k0 += slab_planes) {
        core::Stopwatch w;
        integrator.IntegrateSlab(k0, std::min(grid.nz, k0 + slab_planes), &slab);
        t_fusion += w.ElapsedSeconds();
        cpu_mc0 = std::clock();
        w.Restart();
        mc.AddSlab(slab);
        t_mc += w.ElapsedSeconds();
        cpu_mc += std::clock() - cpu_mc0;
      }
      mesh = mc.Finish();
      best_setup = std::min(best_setup, t_setup);
      best_fusion = std::min(best_fusion, t_fusion + t_setup);
      best_cpu = std::min(best_cpu, double(std::clock() - cpu0 - cpu_mc) / CLOCKS_PER_SEC);
      best_mc = std::min(best_mc, t_mc);
    }
    if (fusion_only) {
      std::printf(
          "{\"cameras\": %zu, \"threads\": %d, \"slab_planes\": %d, \"fusion_s\": %.4f, "
          "\"fusion_cpu_s\": %.4f, \"fusion_setup_s\": %.4f, \"fusion_setup_cpu_s\": %.4f, "
          "\"marching_cubes_s\": %.4f, \"triangles\": %zu}\n",
          images.size(), threads, slab_planes, best_fusion, best_cpu, best_setup, best_setup_cpu,
          best_mc, mesh.faces.size());
      return 0;
    }
    io::WritePly(out / "mesh.ply", mesh);
    core::Stopwatch w;
    mesh::DecimationOptions dec;
    dec.target_ratio = 0.1;
    const io::Mesh decimated = mesh::Decimate(mesh, dec);
    const double t_dec = w.ElapsedSeconds();
    io::WritePly(out / "mesh_decimated.ply", decimated);
    const std::vector<mesh::TextureView> views = mesh::LoadTextureViews(take, instant);
    mesh::TextureOptions tex;
    tex.num_threads = threads;
    io::Mesh coloured = decimated;
    w.Restart();
    mesh::ColorVertices(&coloured, views, tex);
    const double t_tex = w.ElapsedSeconds();
    io::WritePly(out / "mesh_decimated_colored.ply", coloured);
    std::printf(
        "{\"cameras\": %zu, \"image\": \"%dx%d\", \"voxels\": \"%dx%dx%d\", \"voxel_mm\": %g, "
        "\"threads\": %d, \"slab_planes\": %d, \"fusion_s\": %.4f, \"fusion_cpu_s\": %.4f, "
        "\"fusion_setup_s\": %.4f, \"fusion_setup_cpu_s\": %.4f, "
        "\"marching_cubes_s\": %.4f, \"triangles\": %zu, \"decimation_s\": %.4f, "
        "\"decimated_triangles\": %zu, \"texture_vertex_colour_s\": %.4f}\n",
        images.size(), images[0].camera.width_px, images[0].camera.height_px, grid.nx, grid.ny,
        grid.nz, voxel, threads, slab_planes, best_fusion, best_cpu, best_setup, best_setup_cpu,
        best_mc, mesh.faces.size(), t_dec, decimated.faces.size(), t_tex);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fusion_bench: %s\n", e.what());
    return 1;
  }
  return 0;
}
