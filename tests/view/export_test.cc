#include "view/export.h"

#include <gtest/gtest.h>

#include "core/json.h"
#include "io/file_util.h"
#include "testing/run_command.h"
#include "testing/temp_dir.h"
#include "view/assets.h"
#include "view/derived.h"
#include "view_fixture.h"

namespace dome::view {
namespace {

namespace fs = std::filesystem;

const fs::path kAssets = fs::path(DOME_BINARY_DIR) / "share" / "dome" / "viewer";

TEST(Base64, Rfc4648TestVectors) {
  EXPECT_EQ(Base64(""), "");
  EXPECT_EQ(Base64("f"), "Zg==");
  EXPECT_EQ(Base64("fo"), "Zm8=");
  EXPECT_EQ(Base64("foo"), "Zm9v");
  EXPECT_EQ(Base64("foob"), "Zm9vYg==");
  EXPECT_EQ(Base64("fooba"), "Zm9vYmE=");
  EXPECT_EQ(Base64("foobar"), "Zm9vYmFy");
  EXPECT_EQ(Base64(std::string("\xff\x00\xfe", 3)), "/wD+");
}

std::string Packed(const std::string& url, const std::string& bytes) {
  return "domeBlob(" + core::DumpJson(url) + ", \"" + Base64(bytes) + "\");\n";
}

TEST(Export, WritesThePageThePackedIndexAndEveryFileItNames) {
  dome::testing::TempDir tmp;
  const auto f = testing::MakeViewFixture(tmp.path());
  const fs::path dir = tmp / "export";
  const ExportSummary s = ExportStatic(BuildIndex(f.out, f.take), kAssets, dir);
  EXPECT_EQ(s.failed_derived, 0);
  for (const char* file : kAssetFiles)
    EXPECT_EQ(io::ReadFileBytes(dir / file), io::ReadFileBytes(kAssets / file)) << file;
  const std::string index = io::ReadFileBytes(dir / "index.js");
  EXPECT_EQ(index.rfind("window.DOME_INDEX = {", 0), 0u);
  EXPECT_NE(index.find("\"packed\": true"), std::string::npos);
  const std::string i0 = f.instants[0];
  const std::string mesh = "out/" + i0 + "/mesh.ply";
  EXPECT_EQ(io::ReadFileBytes(dir / (mesh + ".js")),
            Packed(mesh, io::ReadFileBytes(f.out / i0 / "mesh.ply")));
  const std::string err = "derived/error/" + i0 + "/fused.f32";
  EXPECT_EQ(io::ReadFileBytes(dir / (err + ".js")),
            Packed(err, VertexErrorFile(BuildIndex(f.out, f.take), 0, MeshVariant::kFused)));
  // Images are plain files (an <img> may load them from file://).
  const std::string frame = "frames/" + i0 + "/c3.png";
  EXPECT_EQ(io::ReadFileBytes(dir / "take" / frame), io::ReadFileBytes(f.take / frame));
  EXPECT_TRUE(fs::is_regular_file(dir / "derived" / "depth" / i0 / "c0.png"));
  EXPECT_FALSE(fs::exists(dir / "derived" / "depth" / i0 / "c1.png"));  // no depth there
  // Nothing of the take besides what the page shows.
  EXPECT_FALSE(fs::exists(dir / "take" / "rig.json"));
}

TEST(Export, UnreadableMeshBecomesAnErrorTheProgramPrints) {
  dome::testing::TempDir tmp;
  const auto f = testing::MakeViewFixture(tmp.path());
  io::WriteFileAtomically(f.out / f.instants[0] / "mesh.ply", "ply\ngarbage");
  const fs::path dir = tmp / "export";
  const ExportSummary s = ExportStatic(BuildIndex(f.out, f.take), kAssets, dir);
  EXPECT_EQ(s.failed_derived, 1);
  const std::string js =
      io::ReadFileBytes(dir / "derived" / "error" / f.instants[0] / "fused.f32.js");
  EXPECT_EQ(js.rfind("domeBlobError(", 0), 0u);
  EXPECT_NE(js.find("mesh.ply"), std::string::npos);
}

TEST(ViewCommand, ExportsAndReportsBadFolders) {
  dome::testing::TempDir tmp;
  const auto f = testing::MakeViewFixture(tmp.path());
  const auto ok = dome::testing::RunDomeBinary("view " + f.out.string() + " --take " +
                                               f.take.string() + " --export " + tmp.File("ex"));
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_NE(ok.output.find("\"instants\": 3"), std::string::npos) << ok.output;
  EXPECT_TRUE(fs::is_regular_file(tmp / "ex" / "index.html"));
  const auto missing = dome::testing::RunDomeBinary("view " + tmp.File("none") + " --port 0");
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_NE(missing.output.find(tmp.File("none")), std::string::npos) << missing.output;
  EXPECT_NE(missing.output.find("expected an output folder"), std::string::npos);
}

}  // namespace
}  // namespace dome::view
