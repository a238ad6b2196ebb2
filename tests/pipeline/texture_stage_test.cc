// The texture stage (pipeline/stages.h Texture) on the small synthetic take: each view
// is cut to where the mesh projects before colouring, and the colours and atlas are
// those of the whole views, to the bit.
#include <gtest/gtest.h>

#include <cmath>

#include "io/ply.h"
#include "mesh/texture.h"
#include "pipeline/small_take_suite.h"
#include "pipeline/stages.h"
#include "take/take.h"

namespace dome::pipeline {
namespace {

class TextureStage : public SmallTakeSuite {};

// The truth mesh's faces of the person (above the floor, inside the dome's shell): a
// surface every camera of the dome sees from outside, so every view is cut.
io::Mesh Person(const io::Mesh& truth) {
  io::Mesh person;
  std::vector<int> index(truth.vertices.size(), -1);
  auto inside = [&](int v) {
    const Eigen::Vector3f& p = truth.vertices[size_t(v)];
    return p.z() > 50 && p.z() < 3000 && std::hypot(p.x(), p.y()) < 3000;
  };
  for (const auto& f : truth.faces) {
    if (!inside(f[0]) || !inside(f[1]) || !inside(f[2])) continue;
    Eigen::Vector3i g;
    for (int k = 0; k < 3; ++k) {
      int& i = index[size_t(f[k])];
      if (i < 0) {
        i = int(person.vertices.size());
        person.vertices.push_back(truth.vertices[size_t(f[k])]);
      }
      g[k] = i;
    }
    person.faces.push_back(g);
  }
  return person;
}

TEST_F(TextureStage, ViewsCutToTheMeshGiveTheColoursAndAtlasOfTheWholeViews) {
  const take::Take take = take::OpenTake(TakeDir());
  const std::string instant = take.instants.front();
  const io::Mesh mesh = Person(io::ReadPly(take.TruthMeshPath(instant)));
  ASSERT_GT(mesh.faces.size(), 100u);
  const std::vector<mesh::TextureView> views = mesh::LoadTextureViews(take, instant);
  mesh::TextureOptions options;
  options.num_threads = 2;

  io::Mesh whole = mesh;
  const auto whole_atlas = mesh::ColourAndAtlas(&whole, views, options, true);
  const TextureResult cut = Texture(mesh, views, options, true);
  ASSERT_TRUE(whole_atlas.has_value());
  ASSERT_TRUE(cut.atlas.has_value());
  ASSERT_EQ(cut.coloured.colors.size(), whole.colors.size());
  EXPECT_TRUE(cut.coloured.colors == whole.colors);
  EXPECT_TRUE(cut.atlas->uv == whole_atlas->uv);
  ASSERT_EQ(cut.atlas->atlas.size(), whole_atlas->atlas.size());
  EXPECT_EQ(cv::norm(cut.atlas->atlas, whole_atlas->atlas, cv::NORM_INF), 0.0);
  // Coloured at all: most vertices took a colour from some view.
  int coloured = 0;
  for (const auto& c : cut.coloured.colors) coloured += c[0] != 0 || c[1] != 0 || c[2] != 0;
  EXPECT_GT(coloured, int(cut.coloured.colors.size()) / 2);
}

}  // namespace
}  // namespace dome::pipeline
