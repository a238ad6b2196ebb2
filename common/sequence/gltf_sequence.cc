#include "sequence/gltf_sequence.h"

#include <vector>

#include "core/error.h"
#include "core/json.h"
#include "mesh/gltf.h"

namespace dome::sequence {

std::string EncodeGltfSequence(const Sequence& sequence) {
  core::Require(!sequence.instants.empty(), "export: sequence", "has no instant");
  const size_t n = sequence.instants.size();
  mesh::GlbBuilder b;
  core::Json document = core::Json::object();
  core::Json nodes = core::Json::array();
  core::Json children = core::Json::array();
  nodes.push_back({{"name", "dome sequence"}, {"matrix", mesh::WorldToGltfMatrix()}});
  for (size_t i = 0; i < n; ++i) {
    const float s = i == 0 ? 1.0f : 0.0f;
    core::Json node = {{"name", sequence.instants[i].name}, {"scale", {s, s, s}}};
    // glTF has no empty mesh (accessors count at least 1): an instant without triangles
    // is a node without one.
    if (!sequence.instants[i].textured.mesh.faces.empty())
      node["mesh"] = b.AddTexturedMesh(sequence.instants[i].textured, &document);
    nodes.push_back(std::move(node));
    children.push_back(i + 1);
  }
  nodes[0]["children"] = children;
  // Keyframe times: every instant's start (seconds, increasing by construction of the
  // timeline from sorted, distinct timecodes).
  std::vector<float> times(n);
  for (size_t i = 0; i < n; ++i) times[i] = float(sequence.instants[i].start_s);
  const int time_accessor = b.AddAccessor(
      b.AddView(times.data(), times.size() * 4, 0), mesh::kGltfFloat, n, "SCALAR", false,
      {{"min", {core::FloatJson(times.front())}}, {"max", {core::FloatJson(times.back())}}});
  core::Json samplers = core::Json::array(), channels = core::Json::array();
  std::vector<float> scale(n * 3);
  for (size_t i = 0; i < n; ++i) {
    for (size_t k = 0; k < n; ++k) {
      const float v = k == i ? 1.0f : 0.0f;
      scale[3 * k] = scale[3 * k + 1] = scale[3 * k + 2] = v;
    }
    const int output = b.AddAccessor(b.AddView(scale.data(), scale.size() * 4, 0),
                                     mesh::kGltfFloat, n, "VEC3", false);
    samplers.push_back({{"input", time_accessor}, {"output", output}, {"interpolation", "STEP"}});
    channels.push_back({{"sampler", i}, {"target", {{"node", i + 1}, {"path", "scale"}}}});
  }
  document["nodes"] = nodes;
  document["scene"] = 0;
  document["scenes"] = {{{"name", "dome sequence"}, {"nodes", {0}}}};
  document["animations"] = {
      {{"name", "sequence"}, {"channels", channels}, {"samplers", samplers}}};
  return b.Finish(document);
}

}  // namespace dome::sequence
