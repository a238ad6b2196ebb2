// The synthetic dome's meshes against its truth (dome synth; synth/batter.h):
//   batter_eval TAKE OUT [--instant TC ...] [--mesh mesh.ply] [--threads N]
// For each instant of OUT (a `dome run` or `dome fuse` output folder of the synthetic
// take TAKE), OUT/<instant>/<mesh> is evaluated (eval/cloud_eval.h, thresholds 5 10 20
// 40 mm, surfaces sampled at 0.01 per mm^2) against truth/<instant>/mesh.ply cropped to
// the person: the box x, y in [-1500, 1500] mm, z in [30, 2600] mm (the room's walls lie
// outside the seed's cube, the floor is trivially exact); and how much of the bat's
// barrel it recovers: the truth triangles within the bat's radius + 25 mm of its axis,
// from 250 mm past the knob (clear of the hands) to its end, the axis from the batter's
// pose at the instant. One JSON line per instant.
#include <CLI/CLI.hpp>
#include <Eigen/Core>
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/error.h"
#include "eval/cloud_eval.h"
#include "io/ply.h"
#include "synth/batter.h"
#include "synth/synth.h"
#include "take/take.h"

using namespace dome;

namespace {

// The faces of `m` whose three vertices pass `keep` (vertices compacted).
io::Mesh KeepFaces(const io::Mesh& m, const std::function<bool(int vertex)>& keep) {
  io::Mesh out;
  std::vector<int> remap(m.vertices.size(), -1);
  for (const auto& f : m.faces) {
    if (!keep(f[0]) || !keep(f[1]) || !keep(f[2])) continue;
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

io::Mesh BatBarrel(const io::Mesh& truth, double time_s) {
  const synth::BatterPose pose = synth::PoseBatter(time_s);
  const Eigen::Vector3d d = pose.bat_dir.normalized();
  return KeepFaces(truth, [&](int v) {
    const Eigen::Vector3d p = truth.vertices[v].cast<double>() - pose.bat_knob_mm;
    const double s = p.dot(d);
    return s >= 250.0 && s <= pose.bat_length_mm + 25.0 &&
           (p - s * d).norm() <= pose.bat_radius_mm + 25.0;
  });
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"The synthetic dome's meshes against its truth: the person and the bat"};
  std::string take_dir, out_dir, mesh_name = "mesh.ply";
  std::vector<std::string> instants;
  int threads = 0;
  app.add_option("TAKE", take_dir, "synthetic take (dome synth)")->required();
  app.add_option("OUT", out_dir, "output folder: OUT/<instant>/<mesh>")->required();
  app.add_option("--instant", instants, "instants (default: every one of the take)");
  app.add_option("--mesh", mesh_name, "mesh file in each instant's folder")->capture_default_str();
  app.add_option("--threads", threads, "threads (0: all)");
  CLI11_PARSE(app, argc, argv);
  try {
    const take::Take take = take::OpenTake(take_dir);
    for (const std::string& instant : instants.empty() ? take.instants : instants) {
      const auto pos = std::find(take.instants.begin(), take.instants.end(), instant);
      if (pos == take.instants.end()) {
        throw core::InputError("--instant", "no instant '" + instant + "' in the take");
      }
      const io::Mesh recon = io::ReadPly(std::filesystem::path(out_dir) / instant / mesh_name);
      const io::Mesh truth = io::ReadPly(take.TruthMeshPath(instant));
      eval::CloudEvalOptions eo;
      eo.thresholds_mm = {5, 10, 20, 40};
      eo.reference_mesh_use = eval::ReferenceMeshUse::kSurface;
      eo.mesh_sample_density_per_mm2 = 0.01;
      eo.reference_sample_density_per_mm2 = 0.01;
      eo.num_threads = threads;
      eo.box_margin = 0.0;
      const Eigen::Vector3f lo(-1500, -1500, 30), hi(1500, 1500, 2600);
      const io::Mesh person = KeepFaces(truth, [&](int v) {
        return (truth.vertices[v].array() >= lo.array()).all() &&
               (truth.vertices[v].array() <= hi.array()).all();
      });
      nlohmann::ordered_json line = {
          {"instant", instant},
          {"vs_truth_person_box", nlohmann::ordered_json::parse(eval::ToJson(
                                      eval::EvaluateReconstruction(recon, person, eo)))}};
      const io::Mesh barrel =
          BatBarrel(truth, synth::InstantTimeS(int(pos - take.instants.begin())));
      if (!barrel.faces.empty()) {
        eval::CloudEvalOptions bo = eo;
        bo.reference_sample_density_per_mm2 = 0.05;
        const auto bat = eval::EvaluateReconstruction(recon, barrel, bo);
        line["bat_barrel"] = {{"truth_samples", bat.n_ref_pts},
                              {"completeness@5mm", bat.scores[0].completeness},
                              {"completeness@10mm", bat.scores[1].completeness},
                              {"completeness@20mm", bat.scores[2].completeness},
                              {"comp_median_mm", bat.comp_median_mm},
                              {"precision@10mm_in_bat_box", bat.scores[1].precision}};
      }
      std::printf("%s\n", line.dump().c_str());
      std::fflush(stdout);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "batter_eval: %s\n", e.what());
    return 1;
  }
  return 0;
}
