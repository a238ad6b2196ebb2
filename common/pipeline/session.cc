#include "pipeline/session.h"

#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/io/zero_copy_stream_impl_lite.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <set>

#include "core/error.h"
#include "core/parallel_for.h"
#include "io/image_io.h"
#include "io/file_util.h"
#include "net/content_hash.h"
#include "pipeline/settings.h"
#include "pipeline/stages.h"
#include "schema/json.h"
#include "silhouette/take_masks.h"
#include "stereo/cluster.h"

namespace dome::pipeline {

namespace fs = std::filesystem;

void SessionOptions::Check() const {
  stereo.Check();
  grid.Check("volume");
  fusion.Check();
  core::Require(slab_planes > 0, "slab_planes",
                "must be positive, got " + std::to_string(slab_planes));
  core::Require(decimate_ratio > 0 && decimate_ratio <= 1, "decimate_ratio",
                "must be in (0, 1], got " + std::to_string(decimate_ratio));
  core::Require(std::isfinite(speck_area_fraction) && speck_area_fraction >= 0 &&
                    speck_area_fraction < 1,
                "speck_area_fraction", "must be in [0, 1), got " + std::to_string(speck_area_fraction));
  core::Require(std::isfinite(speck_diagonal_voxels) && speck_diagonal_voxels >= 0,
                "speck_diagonal_voxels",
                "must be >= 0 voxels, got " + std::to_string(speck_diagonal_voxels));
  core::Require(std::isfinite(speck_gap_voxels) && speck_gap_voxels >= 0, "speck_gap_voxels",
                "must be >= 0 voxels, got " + std::to_string(speck_gap_voxels));
  smooth.Check();
  silhouettes.Check();
  temporal.Check();
}

mesh::DecimationOptions DecimationFor(const SessionOptions& options) {
  mesh::DecimationOptions d;
  d.target_ratio = options.decimate_ratio;
  d.speck_area_fraction = options.speck_area_fraction;
  d.speck_diagonal_mm = options.speck_diagonal_voxels * options.grid.voxel_size_mm;
  d.speck_gap_mm = options.speck_gap_voxels * options.grid.voxel_size_mm;
  return d;
}

runtime::Session ReadSessionJson(const std::filesystem::path& path) {
  runtime::Session session;
  schema::ParseJson(io::ReadFileBytes(path), path.string(), "not a session", &session);
  return session;
}

SessionOptions ResolveSessionOptions(const runtime::Session& s, const std::string& where) {
  SessionOptions o;
  o.stereo = FromStereoSettings(s.stereo(), where, {}, "stereo.");
  o.stereo.write_previews = s.has_write_previews() ? s.write_previews() : true;
  o.grid = FromVolume(s.volume(), where);
  o.fusion = FromFusionSettings(s.fusion(), o.grid.voxel_size_mm, where);
  if (s.has_slab_planes()) o.slab_planes = s.slab_planes();
  if (s.has_decimate_ratio()) o.decimate_ratio = s.decimate_ratio();
  if (s.has_texture()) o.texture = s.texture();
  if (s.has_smooth_iterations()) o.smooth.iterations = s.smooth_iterations();
  if (s.has_smooth_lambda()) o.smooth.lambda = s.smooth_lambda();
  if (s.has_smooth_mu()) o.smooth.mu = s.smooth_mu();
  if (s.has_speck_area_fraction()) o.speck_area_fraction = s.speck_area_fraction();
  if (s.has_speck_diagonal_voxels()) o.speck_diagonal_voxels = s.speck_diagonal_voxels();
  if (s.has_speck_gap_voxels()) o.speck_gap_voxels = s.speck_gap_voxels();
  o.silhouettes = FromSilhouetteSettings(s.silhouettes());
  o.temporal = FromTemporalSettings(s.temporal(), where);
  try {
    o.Check();
  } catch (const core::InputError& e) {
    throw e.Under(where);
  }
  return o;
}

std::vector<std::string> SessionInstants(const runtime::Session& session, const take::Take& take) {
  if (session.instants_size() == 0) return take.instants;
  std::vector<std::string> out;
  for (const std::string& instant : session.instants()) {
    core::Require(
        std::find(take.instants.begin(), take.instants.end(), instant) != take.instants.end(),
        "session: instants", "no instant '" + instant + "' in " + take.dir.string());
    if (std::find(out.begin(), out.end(), instant) == out.end()) out.push_back(instant);
  }
  std::sort(out.begin(), out.end());
  return out;
}

namespace {

// What the masks stage makes each camera's mask from (SessionPlan::mask_inputs). The
// sources are decided, and the given masks' and plates' kinds and sizes checked, here
// (silhouette::TakeMasks), so a bad file fails the submit; no mask is made here: each
// is a job, so a long take's submit reads no more than its files' bytes.
void PlanMasks(const std::function<runtime::BlobRef(const fs::path&, const std::string&)>& add_file,
               SessionPlan* plan) {
  const silhouette::TakeMasks masks(plan->take, silhouette::MaskOptions{});
  std::map<fs::path, runtime::BlobRef> added;  // each file once
  auto add = [&](const fs::path& path, const std::string& name) {
    auto it = added.find(path);
    if (it == added.end()) it = added.emplace(path, add_file(path, name)).first;
    return it->second;
  };
  for (const auto& cam : plan->cameras)
    plan->mask_sources.push_back(silhouette::MaskSourceName(masks.Source(cam)));
  for (size_t t = 0; t < plan->instants.size(); ++t) {
    const std::string& in = plan->instants[t];
    std::vector<std::vector<runtime::BlobRef>> row;
    for (size_t c = 0; c < plan->cameras.size(); ++c) {
      const std::string& cam = plan->cameras[c];
      // The files the mask is made from (the derivation's masks are keyed by them too,
      // frame_handoff.h); the instant's own frame is the plan's.
      std::vector<runtime::BlobRef> inputs;
      for (const auto& path : masks.InputPaths(in, cam)) {
        inputs.push_back(path == plan->take.FramePath(in, cam)
                             ? plan->frames[t][c]
                             : add(path, fs::relative(path, plan->take.dir).generic_string()));
      }
      row.push_back(std::move(inputs));
    }
    plan->mask_inputs.push_back(std::move(row));
  }
}

bool HasPngSignature(const fs::path& path) {
  static const unsigned char kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  std::ifstream in(path, std::ios::binary);
  unsigned char head[8] = {0};
  in.read(reinterpret_cast<char*>(head), 8);
  return in.gcount() == 8 && std::equal(head, head + 8, kSignature);
}
}  // namespace

SessionPlan PlanSession(
    const runtime::Session& spec,
    const std::function<runtime::BlobRef(const fs::path&, const std::string&)>& add_file) {
  SessionPlan plan;
  plan.spec = spec;
  core::Require(!spec.out().empty(), "session: out", "names no output folder");
  plan.options = ResolveSessionOptions(spec, "session");
  if (spec.noop_jobs() > 0) {
    plan.instants = {"noop"};
    return plan;
  }
  core::Require(!spec.take().empty(), "session: take", "names no take folder");
  plan.take = take::OpenTake(spec.take());
  plan.instants = SessionInstants(spec, plan.take);
  core::Require(!plan.instants.empty(), spec.take(), "has no instants");
  // A one-instant session has no previous instant.
  if (plan.instants.size() < 2) plan.options.temporal.stereo = plan.options.temporal.fusion = false;
  for (const auto& rc : plan.take.rig.cameras) plan.cameras.push_back(rc.model.id);
  plan.num_slabs = SlabCount(plan.options.grid, plan.options.slab_planes);
  for (const auto& c : plan.cameras) {
    stereo::SelectCluster(plan.take.rig, c, plan.options.stereo.cluster);
  }
  plan.rig = add_file(plan.take.RigPath(), "rig.json");
  const std::set<std::string> known(plan.cameras.begin(), plan.cameras.end());
  for (const auto& in : plan.instants) {
    // What `dome info` refuses, refused here too, before any job runs: a frame of a
    // camera the rig does not have would otherwise be ignored without a word.
    const fs::path folder = plan.take.dir / "frames" / in;
    for (const auto& e : fs::directory_iterator(folder)) {
      const fs::path p = e.path();
      core::Require(e.is_regular_file() && p.extension() == ".png", p.string(),
                    "unexpected entry (expected <camera>.png files)");
      core::Require(known.count(p.stem().string()) != 0, p.string(),
                    "unknown camera id '" + p.stem().string() + "' (not in rig.json)");
    }
    std::vector<runtime::BlobRef> row;
    for (const auto& c : plan.cameras) {
      const fs::path path = plan.take.FramePath(in, c);
      row.push_back(add_file(path, "frames/" + in + "/" + c + ".png"));
      // The first bytes only: decoding every frame at submit costs as much as a stereo
      // job's reading; a truncated PNG is found by the job that decodes it.
      core::Require(row.back().size() > 0, path.string(), "empty file (0 bytes), expected a PNG");
      core::Require(HasPngSignature(path), path.string(),
                    "not a PNG (it does not start with the PNG signature)");
    }
    plan.frames.push_back(std::move(row));
  }
  if (plan.options.silhouettes.stereo || plan.options.silhouettes.fusion) {
    PlanMasks(add_file, &plan);
  }
  return plan;
}

namespace {
std::string DeterministicBytes(const runtime::Session& s) {
  std::string bytes;
  google::protobuf::io::StringOutputStream stream(&bytes);
  google::protobuf::io::CodedOutputStream coded(&stream);
  coded.SetSerializationDeterministic(true);
  s.SerializeToCodedStream(&coded);
  coded.Trim();
  return bytes;
}
}  // namespace

std::string GivenSessionDigest(const runtime::Session& given, const std::string& extra) {
  runtime::Session canon = given;
  canon.clear_given_sha256();
  canon.clear_derived();
  return net::Sha256Hex(DeterministicBytes(canon) + "\n" + extra);
}

std::string SessionDigest(const SessionPlan& plan) {
  runtime::Session canon;
  // No take for benchmark sessions of no-op jobs (fs::absolute throws on "").
  if (!plan.take.dir.empty())
    canon.set_take(fs::absolute(plan.take.dir).lexically_normal().string());
  for (const auto& in : plan.instants) canon.add_instants(in);
  const SessionOptions& o = plan.options;
  *canon.mutable_stereo() = ToStereoSettings(o.stereo);
  *canon.mutable_volume() = ToVolume(o.grid);
  *canon.mutable_fusion() = ToFusionSettings(o.fusion);
  canon.set_slab_planes(o.slab_planes);
  canon.set_decimate_ratio(o.decimate_ratio);
  canon.set_texture(o.texture);
  canon.set_smooth_iterations(o.smooth.iterations);
  canon.set_smooth_lambda(o.smooth.lambda);
  canon.set_smooth_mu(o.smooth.mu);
  canon.set_speck_area_fraction(o.speck_area_fraction);
  canon.set_speck_diagonal_voxels(o.speck_diagonal_voxels);
  canon.set_speck_gap_voxels(o.speck_gap_voxels);
  canon.set_write_previews(o.stereo.write_previews);
  canon.set_noop_jobs(plan.spec.noop_jobs());
  // Only when on, so that a session without masks keeps the digest it had before.
  if (o.silhouettes.Any()) *canon.mutable_silhouettes() = ToSilhouetteSettings(o.silhouettes);
  if (o.temporal.Any()) *canon.mutable_temporal() = ToTemporalSettings(o.temporal);
  return net::Sha256Hex(DeterministicBytes(canon));
}

std::vector<std::string> InstantInputsDigests(const SessionPlan& plan) {
  std::vector<std::string> digests;
  for (size_t instant = 0; instant < plan.instants.size(); ++instant) {
    std::string addresses = "rig " + plan.rig.sha256() + "\n";
    if (instant < plan.frames.size()) {
      for (size_t c = 0; c < plan.frames[instant].size(); ++c) {
        addresses +=
            plan.frames[instant][c].name() + " " + plan.frames[instant][c].sha256() + "\n";
      }
    }
    if (instant < plan.mask_inputs.size()) {
      for (const auto& inputs : plan.mask_inputs[instant]) {
        for (const auto& m : inputs)
          addresses += "mask input " + m.name() + " " + m.sha256() + "\n";
      }
    }
    if (plan.options.temporal.Any() && instant > 0)
      addresses += "previous " + digests.back() + "\n";
    digests.push_back(net::Sha256Hex(addresses));
  }
  return digests;
}

}  // namespace dome::pipeline
