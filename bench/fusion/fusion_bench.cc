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
#include <nlohmann/json.hpp>
#include <string>

#include "core/timer.h"
#include "fusion/take_inputs.h"
#include "io/file_util.h"
#include "io/ply.h"
#include "pipeline/defaults.h"
#include "pipeline/stages.h"

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
    nlohmann::ordered_json cams = nlohmann::ordered_json::array();
    for (const auto& im : images) {
      io::WriteFileAtomically(out / "depth" / (im.camera.id + ".f32"),
                              std::string(reinterpret_cast<const char*>(im.depth_mm.ptr<float>(0)),
                                          im.depth_mm.total() * 4));
      const Eigen::Matrix3d K = im.camera.K();
      const Eigen::Matrix3d& R = im.camera.rotation;
      const Eigen::Vector3d& t = im.camera.translation_mm;
      cams.push_back(
          {{"id", im.camera.id},
           {"width", im.camera.width_px},
           {"height", im.camera.height_px},
           {"fx", K(0, 0)},
           {"fy", K(1, 1)},
           {"cx", K(0, 2)},
           {"cy", K(1, 2)},
           {"R", {R(0, 0), R(0, 1), R(0, 2), R(1, 0), R(1, 1), R(1, 2), R(2, 0), R(2, 1), R(2, 2)}},
           {"t", {t.x(), t.y(), t.z()}}});
    }
    io::WriteFileAtomically(out / "cameras.json", cams.dump() + "\n");

    // The volume and fusion options every dome command derives (pipeline/defaults.h).
    const fusion::VolumeGrid grid = pipeline::DefaultVolume(voxel);
    fusion::FusionOptions options = pipeline::DefaultFusionOptions(voxel);
    options.num_threads = threads;
    const int num_slabs = pipeline::SlabCount(grid, slab_planes);

    double best_fusion = 1e30, best_mc = 1e30, best_setup = 1e30, best_cpu = 1e30,
           best_setup_cpu = 1e30;
    io::Mesh mesh;
    for (int r = 0; r < std::max(1, repeat); ++r) {
      const std::clock_t cpu0 = std::clock();
      core::Stopwatch setup;
      auto prepared = pipeline::PrepareFusion(grid, images, options);
      const double t_setup = setup.ElapsedSeconds();
      const double setup_cpu = double(std::clock() - cpu0) / CLOCKS_PER_SEC;
      best_setup_cpu = std::min(best_setup_cpu, setup_cpu);
      double t_fusion = 0;
      std::clock_t cpu_fusion = 0;
      fusion::Slab buffer;  // each slab's, reused
      core::Stopwatch surface;
      mesh = pipeline::Surface(
          grid, num_slabs,
          [&](int s) {
            const std::clock_t c0 = std::clock();
            core::Stopwatch w;
            const auto [k0, k1] = pipeline::SlabPlanes(grid, slab_planes, s);
            const fusion::Slab& slab = pipeline::FuseSlab(*prepared, &buffer, k0, k1);
            t_fusion += w.ElapsedSeconds();
            cpu_fusion += std::clock() - c0;
            return std::shared_ptr<const fusion::Slab>(&slab, [](const fusion::Slab*) {});
          },
          {});
      best_setup = std::min(best_setup, t_setup);
      best_fusion = std::min(best_fusion, t_fusion + t_setup);
      // The process CPU time of the table build and the slabs, marching cubes excluded.
      best_cpu = std::min(best_cpu, setup_cpu + double(cpu_fusion) / CLOCKS_PER_SEC);
      best_mc = std::min(best_mc, surface.ElapsedSeconds() - t_fusion);
    }
    nlohmann::ordered_json line = {{"cameras", images.size()},
                                   {"threads", threads},
                                   {"slab_planes", slab_planes},
                                   {"fusion_s", best_fusion},
                                   {"fusion_cpu_s", best_cpu},
                                   {"fusion_setup_s", best_setup},
                                   {"fusion_setup_cpu_s", best_setup_cpu},
                                   {"marching_cubes_s", best_mc},
                                   {"triangles", mesh.faces.size()}};
    if (fusion_only) {
      std::printf("%s\n", line.dump().c_str());
      return 0;
    }
    io::WritePly(out / "mesh.ply", mesh);
    core::Stopwatch w;
    mesh::DecimationOptions dec;
    dec.target_ratio = 0.1;
    const io::Mesh decimated = pipeline::Decimate(mesh, dec);
    const double t_dec = w.ElapsedSeconds();
    io::WritePly(out / "mesh_decimated.ply", decimated);
    const std::vector<mesh::TextureView> views = mesh::LoadTextureViews(take, instant);
    mesh::TextureOptions tex;
    tex.num_threads = threads;
    w.Restart();
    const pipeline::TextureResult coloured = pipeline::Texture(decimated, views, tex, false);
    const double t_tex = w.ElapsedSeconds();
    io::WritePly(out / "mesh_decimated_colored.ply", coloured.coloured);
    line["image"] = std::to_string(images[0].camera.width_px) + "x" +
                    std::to_string(images[0].camera.height_px);
    line["voxels"] =
        std::to_string(grid.nx) + "x" + std::to_string(grid.ny) + "x" + std::to_string(grid.nz);
    line["voxel_mm"] = voxel;
    line["decimation_s"] = t_dec;
    line["decimated_triangles"] = decimated.faces.size();
    line["texture_vertex_colour_s"] = t_tex;
    std::printf("%s\n", line.dump().c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fusion_bench: %s\n", e.what());
    return 1;
  }
  return 0;
}
