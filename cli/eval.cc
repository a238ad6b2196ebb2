// `dome eval cloud RECON REFERENCE` and `dome eval depth ESTIMATE TRUTH`: accuracy
// and completeness against a reference (eval/cloud_eval.h, eval/depth_eval.h). One
// JSON line on stdout (and in --out FILE); a brief report on stderr.
#include <cstdio>
#include <memory>
#include <string>

#include "cli/commands.h"
#include "eval/cloud_eval.h"
#include "eval/depth_eval.h"
#include "io/file_util.h"

namespace dome::cli {
namespace {

void Emit(const std::string& json, const std::string& brief, const std::string& out) {
  std::fputs(brief.c_str(), stderr);
  std::printf("%s\n", json.c_str());
  if (!out.empty()) io::WriteFileAtomically(out, json + "\n");
}

}  // namespace

void AddEvalCommand(CLI::App* app, int* exit_code) {
  auto* cmd = app->add_subcommand("eval", "Accuracy and completeness against a reference (JSON)");
  cmd->require_subcommand(1);

  struct CloudArgs {
    std::string recon, reference, out;
    bool sampled = false, reference_surface = false;
    eval::CloudEvalOptions options;
  };
  auto c = std::make_shared<CloudArgs>();
  auto* cloud = cmd->add_subcommand("cloud", "A mesh or point cloud (PLY) against a reference PLY");
  cloud->add_option("RECON", c->recon, "reconstruction: mesh or point cloud, PLY")->required();
  cloud->add_option("REFERENCE", c->reference, "reference: point cloud or mesh, PLY")->required();
  cloud->add_option("--thresholds", c->options.thresholds_mm, "distance thresholds, mm");
  cloud->add_option("--margin", c->options.box_margin,
                    "evaluation box: reference bbox enlarged by this fraction of its extent");
  cloud->add_option("--recon-unit-mm", c->options.recon_unit_mm, "mm per RECON coordinate unit");
  cloud->add_option("--reference-unit-mm", c->options.reference_unit_mm,
                    "mm per REFERENCE coordinate unit (1000 for a file in metres)");
  cloud->add_option("--mesh-density", c->options.mesh_sample_density_per_mm2,
                    "samples per mm^2 on a mesh reconstruction (accuracy)");
  cloud->add_flag("--sampled", c->sampled,
                  "completeness of a mesh from a dense surface sample, not exact distances");
  cloud->add_flag("--reference-surface", c->reference_surface,
                  "use a reference mesh's surface, not only its vertices");
  cloud->add_option("--threads", c->options.num_threads, "threads (0: all)");
  cloud->add_option("--out", c->out, "also write the JSON to this file");
  cloud->callback([=] {
    c->options.completeness_from_samples = c->sampled;
    if (c->reference_surface) c->options.reference_mesh_use = eval::ReferenceMeshUse::kSurface;
    const auto report = eval::EvaluateReconstructionFiles(c->recon, c->reference, c->options);
    Emit(eval::ToJson(report), report.BriefReport(), c->out);
    *exit_code = 0;
  });

  struct DepthArgs {
    std::string estimate, truth, mask, out;
    eval::DepthEvalOptions options;
  };
  auto d = std::make_shared<DepthArgs>();
  auto* depth = cmd->add_subcommand("depth", "A depth map against ground-truth depth (mm)");
  depth->add_option("ESTIMATE", d->estimate, "depth map: 32-bit float TIFF or 16-bit PNG, mm")
      ->required();
  depth->add_option("TRUTH", d->truth, "ground-truth depth map, same encodings")->required();
  depth->add_option("--tolerances", d->options.tolerances_mm, "error tolerances, mm");
  depth->add_option("--mask", d->mask, "8-bit mask: evaluate where non-zero");
  depth->add_option("--out", d->out, "also write the JSON to this file");
  depth->callback([=] {
    const auto report = eval::EvaluateDepthFiles(d->estimate, d->truth, d->options, d->mask);
    Emit(eval::ToJson(report), report.BriefReport(), d->out);
    *exit_code = 0;
  });
}

}  // namespace dome::cli
