// Texture benchmark on one instant of a take: per-vertex colours (ColorVertices) and the
// texture atlas (BuildTextureAtlas) of a mesh, e.g. the mesh_decimated.ply that
// `dome run TAKE --out OUT --instant I` writes for that instant. Times are wall seconds,
// best of --repeat. With --reference 1 it also times the exhaustive reference
// (TextureOptions::exhaustive: every camera tested at every texel with
// TsaiCamera::ProjectCamera) and compares the two outputs: texels / vertices whose colour
// differs and the largest difference in any channel (levels of 0..255). Prints one JSON
// line; *_cpu_s are the process's CPU seconds for the same runs (steadier than wall time
// on a machine shared with other work). colour_and_atlas_s times both from one
// preparation of the views (mesh::ColourAndAtlas, the texture job's call).
//
//   texture_bench TAKE INSTANT MESH.ply [--threads N] [--repeat R] [--reference 0|1]
//                 [--cell-px S] [--out DIR]   (DIR/textured.obj + .mtl + .png)
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <string>
#include <vector>

#include "core/json.h"
#include "core/timer.h"
#include "io/image_io.h"
#include "io/ply.h"
#include "mesh/texture.h"
#include "take/take.h"

using namespace dome;

namespace {

double CpuSeconds() { return double(std::clock()) / CLOCKS_PER_SEC; }

struct Timed {
  double vertex_s = 1e30, atlas_s = 1e30, vertex_cpu_s = 1e30, atlas_cpu_s = 1e30;
  double both_s = 1e30, both_cpu_s = 1e30;  // ColourAndAtlas: what the texture job runs
  io::Mesh coloured;
  mesh::TexturedMesh textured;
};

Timed Run(const io::Mesh& m, const std::vector<mesh::TextureView>& views,
          const mesh::TextureOptions& options, int repeat) {
  Timed t;
  for (int r = 0; r < repeat; ++r) {
    t.coloured = m;
    core::Stopwatch w;
    double cpu = CpuSeconds();
    mesh::ColorVertices(&t.coloured, views, options);
    t.vertex_s = std::min(t.vertex_s, w.ElapsedSeconds());
    t.vertex_cpu_s = std::min(t.vertex_cpu_s, CpuSeconds() - cpu);
    w.Restart();
    cpu = CpuSeconds();
    t.textured = mesh::BuildTextureAtlas(m, views, options);
    t.atlas_s = std::min(t.atlas_s, w.ElapsedSeconds());
    t.atlas_cpu_s = std::min(t.atlas_cpu_s, CpuSeconds() - cpu);
    io::Mesh both = m;
    w.Restart();
    cpu = CpuSeconds();
    mesh::ColourAndAtlas(&both, views, options, true);
    t.both_s = std::min(t.both_s, w.ElapsedSeconds());
    t.both_cpu_s = std::min(t.both_cpu_s, CpuSeconds() - cpu);
  }
  return t;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4) {
    std::fprintf(stderr,
                 "usage: texture_bench TAKE INSTANT MESH.ply [--threads N] [--repeat R] "
                 "[--reference 0|1] [--cell-px S] [--out DIR]\n");
    return 2;
  }
  int threads = 1, repeat = 3;
  bool reference = false;
  std::string out;
  mesh::TextureOptions options;
  for (int a = 4; a + 1 < argc; a += 2) {
    const std::string k = argv[a];
    if (k == "--threads") {
      threads = std::atoi(argv[a + 1]);
    } else if (k == "--repeat") {
      repeat = std::max(1, std::atoi(argv[a + 1]));
    } else if (k == "--reference") {
      reference = std::atoi(argv[a + 1]) != 0;
    } else if (k == "--cell-px") {
      options.atlas_cell_px = std::atoi(argv[a + 1]);
    } else if (k == "--out") {
      out = argv[a + 1];
    } else {
      std::fprintf(stderr, "texture_bench: unknown option %s\n", k.c_str());
      return 2;
    }
  }
  options.num_threads = threads;
  try {
    const take::Take take = take::OpenTake(argv[1]);
    const std::string instant = argv[2];
    const io::Mesh m = io::ReadPly(argv[3]);
    const std::vector<mesh::TextureView> views = mesh::LoadTextureViews(take, instant);
    const Timed fast = Run(m, views, options, repeat);
    if (!out.empty()) {
      std::filesystem::create_directories(out);
      mesh::WriteTexturedObj(std::filesystem::path(out) / "textured.obj", fast.textured);
    }
    const auto size = [](int w, int h) { return std::to_string(w) + "x" + std::to_string(h); };
    core::Json line = {
        {"cameras", views.size()},
        {"image", views.empty() ? "0x0"
                                : size(views[0].camera.width_px, views[0].camera.height_px)},
        {"vertices", m.vertices.size()},
        {"triangles", m.faces.size()},
        {"atlas", size(fast.textured.atlas.cols, fast.textured.atlas.rows)},
        {"threads", threads},
        {"vertex_colour_s", fast.vertex_s},
        {"atlas_s", fast.atlas_s},
        {"vertex_colour_cpu_s", fast.vertex_cpu_s},
        {"atlas_cpu_s", fast.atlas_cpu_s},
        {"colour_and_atlas_s", fast.both_s},
        {"colour_and_atlas_cpu_s", fast.both_cpu_s}};
    if (reference) {
      mesh::TextureOptions ro = options;
      ro.exhaustive = true;
      const Timed ref = Run(m, views, ro, 1);
      int vertex_diff = 0, vertex_max = 0;
      for (size_t i = 0; i < m.vertices.size(); ++i) {
        int d = 0;
        for (int c = 0; c < 3; ++c) {
          d = std::max(d,
                       std::abs(int(fast.coloured.colors[i][c]) - int(ref.coloured.colors[i][c])));
        }
        vertex_diff += d > 0;
        vertex_max = std::max(vertex_max, d);
      }
      int texel_diff = 0, texel_max = 0;
      const cv::Mat& a = fast.textured.atlas;
      const cv::Mat& b = ref.textured.atlas;
      for (int y = 0; y < a.rows; ++y) {
        for (int x = 0; x < a.cols; ++x) {
          int d = 0;
          for (int c = 0; c < 3; ++c) {
            d = std::max(d,
                         std::abs(int(a.at<cv::Vec3b>(y, x)[c]) - int(b.at<cv::Vec3b>(y, x)[c])));
          }
          texel_diff += d > 0;
          texel_max = std::max(texel_max, d);
        }
      }
      line["reference_vertex_colour_s"] = ref.vertex_s;
      line["reference_atlas_s"] = ref.atlas_s;
      line["reference_vertex_colour_cpu_s"] = ref.vertex_cpu_s;
      line["reference_atlas_cpu_s"] = ref.atlas_cpu_s;
      line["speedup"] = (ref.vertex_s + ref.atlas_s) / (fast.vertex_s + fast.atlas_s);
      line["speedup_cpu"] =
          (ref.vertex_cpu_s + ref.atlas_cpu_s) / (fast.vertex_cpu_s + fast.atlas_cpu_s);
      line["vertices_differing"] = vertex_diff;
      line["vertex_max_diff"] = vertex_max;
      line["texels_differing"] = texel_diff;
      line["texel_max_diff"] = texel_max;
    }
    core::PrintJsonLine(line);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "texture_bench: %s\n", e.what());
    return 1;
  }
  return 0;
}
