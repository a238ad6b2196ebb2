#include "eval/cloud_eval.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <iostream>
#include <map>
#include <optional>
#include <random>

#include "../io/test_util.h"
#include "core/timer.h"
#include "io/ply.h"

namespace dome::eval {
namespace {

using ::dome::testing::ExpectInputError;
using ::dome::testing::TempDir;
using Eigen::Vector3f;

const std::filesystem::path kShared(DOME_SHARED_DIR);
const std::filesystem::path kScript = kShared / "tools/eval_cloud.py";
const std::filesystem::path kReference =
    kShared / "data/robovision/2016_10_24__17_43_02/reference.ply";

// A square grid of points in the plane z = `z`, `n` x `n` with `spacing` (mm).
io::Mesh Grid(int n, float spacing, float z, float x0 = 0.0f) {
  io::Mesh m;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      m.vertices.emplace_back(x0 + i * spacing, j * spacing, z);
    }
  }
  return m;
}

// The square [0, size]^2 at height z as two triangles.
io::Mesh Square(float size, float z) {
  io::Mesh m;
  m.vertices = {{0, 0, z}, {size, 0, z}, {size, size, z}, {0, size, z}};
  m.faces = {{0, 1, 2}, {0, 2, 3}};
  return m;
}

CloudEvalOptions Mm() {
  CloudEvalOptions o;
  o.recon_unit_mm = 1.0;
  o.reference_unit_mm = 1.0;
  return o;
}

TEST(EvaluateReconstruction, PlaneCloudOffsetByOneMillimetre) {
  const io::Mesh reference = Grid(50, 0.5f, 0.0f);
  const io::Mesh recon = Grid(50, 0.5f, 1.0f);
  const CloudEvalReport r = EvaluateReconstruction(recon, reference, Mm());
  EXPECT_EQ(r.kind, "cloud");
  EXPECT_EQ(r.n_recon_pts, 2500);
  // The reference is flat, so its box has zero height: z = 1 is outside it.
  EXPECT_EQ(r.n_in_box, 0);
  EXPECT_FALSE(r.has_accuracy());

  // Give the reference some height (one point at z = 10) so z = 1 is inside the box.
  io::Mesh thick = reference;
  thick.vertices.emplace_back(100.0f, 100.0f, 10.0f);
  const CloudEvalReport t = EvaluateReconstruction(recon, thick, Mm());
  EXPECT_EQ(t.n_in_box, 2500);
  EXPECT_DOUBLE_EQ(t.acc_median_mm, 1.0);
  EXPECT_DOUBLE_EQ(t.acc_mean_mm, 1.0);
  EXPECT_DOUBLE_EQ(t.acc_p90_mm, 1.0);
  EXPECT_NEAR(t.ref_spacing_median_mm, 0.5, 1e-6);
  ASSERT_EQ(t.scores.size(), 3u);
  EXPECT_EQ(t.scores[0].precision, 0.0);                 // @0.5 mm
  EXPECT_EQ(t.scores[1].precision, 1.0);                 // @1 mm
  EXPECT_EQ(t.scores[2].precision, 1.0);                 // @2 mm
  EXPECT_EQ(t.scores[1].completeness, 2500.0 / 2501.0);  // all but the far point
}

TEST(EvaluateReconstruction, HalfCoveredReferenceIsHalfComplete) {
  const io::Mesh reference = Grid(40, 1.0f, 0.0f);  // x in [0, 39]
  io::Mesh recon;
  for (const Vector3f& v : reference.vertices) {
    if (v.x() < 19.5f) {
      recon.vertices.push_back(v);  // x in [0, 19]: exactly half
    }
  }
  const CloudEvalReport r = EvaluateReconstruction(recon, reference, Mm());
  ASSERT_EQ(r.scores.size(), 3u);
  EXPECT_DOUBLE_EQ(r.scores[0].completeness, 0.5);  // @0.5 mm: uncovered points are >= 1 mm away
  EXPECT_DOUBLE_EQ(r.scores[0].precision, 1.0);
  EXPECT_DOUBLE_EQ(r.scores[0].fscore, 2 * 0.5 / 1.5);
  EXPECT_DOUBLE_EQ(r.acc_median_mm, 0.0);
  // The uncovered half is 1..20 mm away: the median reference point sits at the seam.
  EXPECT_DOUBLE_EQ(r.comp_median_mm, 0.5);
}

TEST(EvaluateReconstruction, MeshReconstructionUsesExactSurfaceDistance) {
  io::Mesh reference = Grid(21, 0.5f, 0.0f);          // [0, 10]^2, every 0.5 mm
  reference.vertices.emplace_back(5.0f, 5.0f, 5.0f);  // gives the box height
  const io::Mesh recon = Square(10.0f, 1.0f);
  const CloudEvalReport r = EvaluateReconstruction(recon, reference, Mm());
  EXPECT_EQ(r.kind, "mesh");
  EXPECT_EQ(r.n_triangles, 2);
  EXPECT_EQ(r.n_recon_pts, 2000);  // 100 mm^2 x 20 / mm^2
  EXPECT_EQ(r.completeness_method, "point_to_triangle");
  // Every grid point is exactly 1 mm below the square; the extra point 4 mm above.
  EXPECT_DOUBLE_EQ(r.comp_median_mm, 1.0);
  EXPECT_DOUBLE_EQ(r.scores[1].completeness, 441.0 / 442.0);
  EXPECT_EQ(r.scores[0].completeness, 0.0);
  // Samples are 1 mm above the grid and at most half a diagonal cell sideways.
  EXPECT_GE(r.acc_median_mm, 1.0 - 1e-6);
  EXPECT_LE(r.acc_p90_mm, std::sqrt(1.0 + 0.125) + 1e-6);

  CloudEvalOptions sampled = Mm();
  sampled.completeness_from_samples = true;
  const CloudEvalReport s = EvaluateReconstruction(recon, reference, sampled);
  EXPECT_EQ(s.completeness_method, "surface_sample");
  EXPECT_NEAR(s.comp_median_mm, 1.0, 0.01);  // 400 / mm^2: ~0.05 mm apart
}

TEST(EvaluateReconstruction, ReferenceMeshAsSurface) {
  const io::Mesh reference = Square(10.0f, 0.0f);
  io::Mesh recon = Grid(21, 0.5f, 0.0f);
  for (Vector3f& v : recon.vertices) {
    v.z() = 0.0f;
  }
  // The reference box is flat; widen it with a recon-independent margin by adding a
  // vertex that no face uses.
  io::Mesh ref = reference;
  ref.vertices.emplace_back(5.0f, 5.0f, 2.0f);
  for (Vector3f& v : recon.vertices) {
    v.z() = 0.3f;
  }
  CloudEvalOptions o = Mm();
  o.reference_mesh_use = ReferenceMeshUse::kSurface;
  const CloudEvalReport r = EvaluateReconstruction(recon, ref, o);
  EXPECT_EQ(r.n_ref_pts, 2000);  // 100 mm^2 x 20 / mm^2
  EXPECT_EQ(r.n_in_box, 441);
  EXPECT_NEAR(r.acc_median_mm, 0.3, 1e-6);  // exact distance to the reference plane
  EXPECT_NEAR(r.acc_p90_mm, 0.3, 1e-6);
  EXPECT_GE(r.comp_median_mm, 0.3 - 1e-6);
  EXPECT_LE(r.comp_median_mm, std::sqrt(0.09 + 0.125));

  o.reference_mesh_use = ReferenceMeshUse::kVertices;  // 5 vertices: far worse
  const CloudEvalReport v = EvaluateReconstruction(recon, ref, o);
  EXPECT_EQ(v.n_ref_pts, 5);
  EXPECT_GT(v.acc_median_mm, 2.0);
}

TEST(EvaluateReconstruction, BoxMarginAndUnits) {
  io::Mesh reference = Grid(11, 1.0f, 0.0f);           // x, y in [0, 10]
  reference.vertices.emplace_back(0.0f, 0.0f, 10.0f);  // z in [0, 10]
  // Margin 0.1: half extent 5.5 about 5, so the box is [-0.5, 10.5]^3.
  io::Mesh recon;
  recon.vertices = {{10.4f, 5, 5},  {10.6f, 5, 5},  {-0.45f, 5, 5}, {-0.55f, 5, 5},
                    {5, 5, 10.49f}, {5, 5, 10.51f}, {5, 5, 5}};
  CloudEvalOptions o = Mm();
  const CloudEvalReport r = EvaluateReconstruction(recon, reference, o);
  EXPECT_EQ(r.n_in_box, 4);
  EXPECT_EQ(r.n_outside_box, 3);
  EXPECT_DOUBLE_EQ(r.frac_outside_box, 3.0 / 7.0);
  EXPECT_NEAR(r.box_min_mm.x(), -0.5, 1e-9);
  EXPECT_NEAR(r.box_max_mm.z(), 10.5, 1e-9);
  o.box_margin = 0.0;
  EXPECT_EQ(EvaluateReconstruction(recon, reference, o).n_in_box, 1);

  // The reference in metres and the reconstruction in mm give the same report.
  io::Mesh reference_m = reference;
  for (Vector3f& v : reference_m.vertices) {
    v /= 1000.0f;
  }
  CloudEvalOptions units = Mm();
  units.reference_unit_mm = 1000.0;
  const CloudEvalReport u = EvaluateReconstruction(recon, reference_m, units);
  EXPECT_EQ(u.n_in_box, r.n_in_box);
  EXPECT_NEAR(u.acc_mean_mm, r.acc_mean_mm, 1e-4);
  EXPECT_NEAR(u.ref_spacing_median_mm, 1.0, 1e-4);
}

TEST(EvaluateReconstruction, EmptyReconstruction) {
  const CloudEvalReport r = EvaluateReconstruction(io::Mesh{}, Grid(5, 1.0f, 0.0f), Mm());
  EXPECT_EQ(r.n_recon_pts, 0);
  EXPECT_FALSE(r.has_accuracy());
  EXPECT_EQ(r.scores[2].completeness, 0.0);
  EXPECT_EQ(r.scores[2].fscore, 0.0);
  const std::string json = ToJson(r);
  EXPECT_NE(json.find("\"acc_median_mm\": null"), std::string::npos) << json;
  EXPECT_NE(json.find("\"precision@2mm\": null"), std::string::npos) << json;
  EXPECT_NE(json.find("\"completeness@2mm\": 0"), std::string::npos) << json;
  EXPECT_NE(json.find("\"frac_outside_box\": null"), std::string::npos) << json;
}

TEST(EvaluateReconstruction, DeterministicForAnyThreadCount) {
  io::Mesh reference = Grid(30, 0.7f, 0.0f);
  reference.vertices.emplace_back(0.0f, 0.0f, 3.0f);
  io::Mesh recon = Square(20.0f, 0.2f);
  CloudEvalOptions o = Mm();
  o.num_threads = 1;
  const std::string one = ToJson(EvaluateReconstruction(recon, reference, o));
  o.num_threads = 4;
  EXPECT_EQ(ToJson(EvaluateReconstruction(recon, reference, o)), one);
  EXPECT_NE(one.find("\"n_in_box\": 8000"), std::string::npos) << one;
  o.seed = 9;
  EXPECT_NE(ToJson(EvaluateReconstruction(recon, reference, o)), one);
}

TEST(EvaluateReconstruction, BadInputsAndOptionsNameWhat) {
  ExpectInputError([] { EvaluateReconstruction(Grid(2, 1, 0), io::Mesh{}, Mm()); },
                   {"reference", "has no points"});
  io::Mesh broken = Square(1.0f, 0.0f);
  broken.faces.emplace_back(0, 1, 7);
  ExpectInputError([&] { EvaluateReconstruction(broken, Grid(2, 1, 0), Mm()); },
                   {"reconstruction", "face 2 refers to vertex 7"});
  io::Mesh flat = Square(1.0f, 0.0f);
  flat.vertices[2] = flat.vertices[1];
  flat.vertices[3] = flat.vertices[1];
  ExpectInputError([&] { EvaluateReconstruction(flat, Grid(2, 1, 0), Mm()); },
                   {"reconstruction", "zero surface area"});
  CloudEvalOptions o;
  o.thresholds_mm = {1.0, 0.0};
  ExpectInputError([&] { o.Check(); }, {"thresholds_mm[1]"});
  o = CloudEvalOptions();
  o.recon_unit_mm = -1;
  ExpectInputError([&] { o.Check(); }, {"recon_unit_mm"});
  o = CloudEvalOptions();
  o.box_margin = NAN;
  ExpectInputError([&] { o.Check(); }, {"box_margin"});

  TempDir dir;
  io::WritePly(dir / "empty.ply", io::Mesh{});
  io::WritePly(dir / "grid.ply", Grid(3, 1, 0));
  ExpectInputError([&] { EvaluateReconstructionFiles(dir / "grid.ply", dir / "empty.ply", Mm()); },
                   {(dir / "empty.ply").string(), "has no points"});
  ExpectInputError([&] { EvaluateReconstructionFiles(dir / "nope.ply", dir / "grid.ply", Mm()); },
                   {"nope.ply", "no such file"});
}

// ---------------------------------------------------------------------------------
// Agreement with ../tools/eval_cloud.py.

bool ScriptAvailable() {
  static const bool available =
      std::filesystem::exists("/usr/bin/python3") && std::filesystem::exists(kScript) &&
      std::system("/usr/bin/python3 -c 'import open3d, scipy.spatial' >/dev/null 2>&1") == 0;
  return available;
}

struct ScriptRun {
  std::string json;
  double seconds = 0.0;
};

ScriptRun RunScript(const std::string& args) {
  const std::string command =
      "/usr/bin/python3 '" + kScript.string() + "' " + args + " 2>/dev/null";
  const core::Stopwatch watch;
  FILE* pipe = popen(command.c_str(), "r");
  EXPECT_NE(pipe, nullptr);
  ScriptRun run;
  if (pipe == nullptr) {
    return run;
  }
  char buf[4096];
  while (fgets(buf, sizeof(buf), pipe) != nullptr) {
    run.json += buf;
  }
  EXPECT_EQ(pclose(pipe), 0) << command;
  run.seconds = watch.ElapsedSeconds();
  return run;
}

// The number after "key": in a flat JSON object; NaN for null, nullopt when absent.
std::optional<double> JsonValue(const std::string& json, const std::string& key) {
  const std::string needle = "\"" + key + "\": ";
  const size_t at = json.find(needle);
  if (at == std::string::npos) {
    return std::nullopt;
  }
  const char* start = json.c_str() + at + needle.size();
  if (std::strncmp(start, "null", 4) == 0) {
    return NAN;
  }
  return std::strtod(start, nullptr);
}

// Compares every numeric key the two reports share; counts exactly when `exact_counts`.
void ExpectAgreement(const std::string& ours, const std::string& theirs, bool exact_counts,
                     double rel_tol = 0.02) {
  const char* counts[] = {"n_recon_pts", "n_in_box", "n_outside_box", "n_ref_pts", "n_triangles"};
  std::vector<std::string> keys = {"ref_spacing_median_mm", "acc_median_mm",
                                   "acc_mean_mm",           "acc_p90_mm",
                                   "comp_median_mm",        "frac_outside_box"};
  for (const char* t : {"0.5", "1", "2"}) {
    for (const char* k : {"precision@", "completeness@", "fscore@"}) {
      keys.push_back(std::string(k) + t + "mm");
    }
  }
  std::printf("    %-24s %14s %14s %9s\n", "key", "dome", "eval_cloud.py", "rel.diff");
  for (const char* key : counts) {
    const auto a = JsonValue(ours, key), b = JsonValue(theirs, key);
    if (!b) {
      continue;
    }
    ASSERT_TRUE(a) << key;
    std::printf("    %-24s %14.0f %14.0f %9.5f\n", key, *a, *b,
                std::abs(*a - *b) / std::max(1.0, *b));
    if (exact_counts) {
      EXPECT_EQ(*a, *b) << key;
    } else {
      EXPECT_NEAR(*a, *b, rel_tol * *b) << key;
    }
  }
  for (const std::string& key : keys) {
    const auto a = JsonValue(ours, key), b = JsonValue(theirs, key);
    ASSERT_TRUE(b) << key << " missing from the script's output " << theirs;
    ASSERT_TRUE(a) << key << " missing from ours " << ours;
    const double rel = std::abs(*a - *b) / std::max(std::abs(*b), 1e-12);
    std::printf("    %-24s %14.6f %14.6f %9.5f\n", key.c_str(), *a, *b, rel);
    // The script rounds to 4 decimals.
    EXPECT_NEAR(*a, *b, std::max(rel_tol * std::abs(*b), 1.5e-4)) << key;
  }
}

TEST(EvalCloudAgreement, PerturbedRobovisionCloud) {
  if (!ScriptAvailable()) {
    GTEST_SKIP() << "no /usr/bin/python3 with open3d and scipy";
  }
  if (!std::filesystem::exists(kReference)) {
    GTEST_SKIP() << "no shared data";
  }
  TempDir dir;
  const io::Mesh reference = io::ReadPly(kReference);
  // Perturb (in metres): drop the 30% of points with the largest x, add 0.3 mm
  // Gaussian noise, add 300 outliers inside the box and 1000 outside it.
  std::vector<float> xs;
  for (const Vector3f& v : reference.vertices) {
    xs.push_back(v.x());
  }
  std::nth_element(xs.begin(), xs.begin() + xs.size() * 7 / 10, xs.end());
  const float x_cut = xs[xs.size() * 7 / 10];
  Eigen::Vector3f lo = reference.vertices[0], hi = lo;
  for (const Vector3f& v : reference.vertices) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  const Vector3f extent = hi - lo;
  std::mt19937_64 gen(2024);
  std::normal_distribution<double> noise(0.0, 0.0003);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  io::Mesh perturbed;
  for (const Vector3f& v : reference.vertices) {
    if (v.x() > x_cut) {
      continue;
    }
    perturbed.vertices.push_back(v + Vector3f(noise(gen), noise(gen), noise(gen)));
  }
  for (int i = 0; i < 300; ++i) {
    perturbed.vertices.push_back(lo + Vector3f(u(gen), u(gen), u(gen)).cwiseProduct(extent));
  }
  for (int i = 0; i < 1000; ++i) {
    const Vector3f offset = (0.6f + u(gen)) * extent;  // beyond the 0.55-extent half box
    const Vector3f centre = (lo + hi) / 2;
    perturbed.vertices.push_back(i % 2 ? Vector3f(centre + offset) : Vector3f(centre - offset));
  }
  const auto recon_path = dir / "perturbed.ply";
  io::WritePly(recon_path, perturbed);

  CloudEvalOptions o;
  o.recon_unit_mm = o.reference_unit_mm = 1000.0;  // the files are in metres
  const core::Stopwatch watch;
  const CloudEvalReport ours = EvaluateReconstructionFiles(recon_path, kReference, o);
  const double our_seconds = watch.ElapsedSeconds();
  const ScriptRun theirs = RunScript("'" + recon_path.string() + "' '" + kReference.string() + "'");
  std::printf("  perturbed Robovision cloud (%zu points) vs reference.ply (%zu points)\n",
              perturbed.vertices.size(), reference.vertices.size());
  ExpectAgreement(ToJson(ours), theirs.json, /*exact_counts=*/true);
  std::printf(
      "    time: dome %.3f s (evaluation %.3f s, rest is PLY reading); eval_cloud.py %.3f s\n",
      our_seconds, ours.seconds, theirs.seconds);
  EXPECT_EQ(ours.n_outside_box, 1000);
}

// An icosphere of the given radius (mm) and subdivision level.
io::Mesh Icosphere(float radius, int levels) {
  const float t = (1.0f + std::sqrt(5.0f)) / 2.0f;
  io::Mesh m;
  m.vertices = {{-1, t, 0},  {1, t, 0},  {-1, -t, 0}, {1, -t, 0}, {0, -1, t},  {0, 1, t},
                {0, -1, -t}, {0, 1, -t}, {t, 0, -1},  {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
  m.faces = {{0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
             {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
             {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (int level = 0; level < levels; ++level) {
    std::map<std::pair<int, int>, int> midpoint;
    auto mid = [&](int a, int b) {
      const auto key = std::minmax(a, b);
      auto it = midpoint.find(key);
      if (it != midpoint.end()) {
        return it->second;
      }
      m.vertices.push_back((m.vertices[a] + m.vertices[b]) / 2);
      return midpoint[key] = static_cast<int>(m.vertices.size()) - 1;
    };
    std::vector<Eigen::Vector3i> faces;
    for (const auto& f : m.faces) {
      const int ab = mid(f[0], f[1]), bc = mid(f[1], f[2]), ca = mid(f[2], f[0]);
      faces.insert(faces.end(), {{f[0], ab, ca}, {f[1], bc, ab}, {f[2], ca, bc}, {ab, bc, ca}});
    }
    m.faces = std::move(faces);
  }
  for (Vector3f& v : m.vertices) {
    v = v.normalized() * radius;
  }
  return m;
}

TEST(EvalCloudAgreement, SphereMeshAgainstNoisyPartialReference) {
  if (!ScriptAvailable()) {
    GTEST_SKIP() << "no /usr/bin/python3 with open3d and scipy";
  }
  TempDir dir;
  const io::Mesh sphere = Icosphere(10.0f, 4);  // 5120 triangles, ~1255 mm^2
  // Reference: 20000 points about the sphere with 0.5 mm radial noise, only z > -4 mm.
  std::mt19937_64 gen(77);
  std::normal_distribution<float> normal(0.0f, 1.0f);
  io::Mesh reference;
  while (reference.vertices.size() < 20000) {
    const Vector3f dir3 = Vector3f(normal(gen), normal(gen), normal(gen)).normalized();
    const Vector3f p = dir3 * (10.0f + 0.5f * normal(gen));
    if (p.z() > -4.0f) {
      reference.vertices.push_back(p);
    }
  }
  io::WritePly(dir / "sphere.ply", sphere);
  io::WritePly(dir / "reference.ply", reference);

  CloudEvalOptions o = Mm();
  o.mesh_sample_density_per_mm2 = 50.0;
  const core::Stopwatch watch;
  const CloudEvalReport ours =
      EvaluateReconstructionFiles(dir / "sphere.ply", dir / "reference.ply", o);
  const double our_seconds = watch.ElapsedSeconds();
  const ScriptRun theirs =
      RunScript("'" + (dir / "sphere.ply").string() + "' '" + (dir / "reference.ply").string() +
                "' --unit 1 --mesh-density 50");
  std::printf("  icosphere mesh (5120 triangles) vs noisy partial reference (20000 points)\n");
  // Mesh samples differ (different generators), so counts agree only statistically.
  ExpectAgreement(ToJson(ours), theirs.json, /*exact_counts=*/false);
  std::printf("    time: dome %.3f s; eval_cloud.py %.3f s\n", our_seconds, theirs.seconds);
  EXPECT_EQ(ours.kind, "mesh");
  EXPECT_EQ(ours.n_recon_pts, *JsonValue(theirs.json, "n_recon_pts"));
}

}  // namespace
}  // namespace dome::eval
