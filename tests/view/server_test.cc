#include "view/server.h"

#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <thread>

#include "io/file_util.h"
#include "testing/expect_error.h"
#include "testing/temp_dir.h"
#include "view/derived.h"
#include "view_fixture.h"

namespace dome::view {
namespace {

namespace fs = std::filesystem;
using testing::RawGet;

const fs::path kAssets = fs::path(DOME_BINARY_DIR) / "share" / "dome" / "viewer";
const std::string kSecret = "dome-test-secret-4711";

class ServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    f_ = testing::MakeViewFixture(tmp_.path());
    std::ofstream(tmp_ / "secret.txt") << kSecret;  // beside OUT and TAKE, never served
    fs::create_symlink(tmp_ / "secret.txt", f_.out / f_.instants[0] / "escape.ply");
    ServerOptions o;
    o.port = 0;
    server_ = std::make_unique<ViewerServer>(f_.out, f_.take, kAssets, o);
    port_ = server_->Bind();
    thread_ = std::thread([this] { server_->Run(); });
  }
  void TearDown() override {
    server_->Stop();
    thread_.join();
  }
  testing::HttpReply Get(const std::string& target) { return RawGet(port_, target); }

  dome::testing::TempDir tmp_;
  testing::ViewFixture f_;
  std::unique_ptr<ViewerServer> server_;
  int port_ = 0;
  std::thread thread_;
};

TEST_F(ServerTest, ServesThePageIndexAndFiles) {
  const auto page = Get("/");
  EXPECT_EQ(page.status, 200);
  EXPECT_NE(page.body.find("<title>dome view</title>"), std::string::npos);
  const auto index = Get("/index.js");
  EXPECT_EQ(index.status, 200);
  EXPECT_EQ(index.body.rfind("window.DOME_INDEX = {", 0), 0u);
  EXPECT_NE(index.body.find("\"out/" + f_.instants[0] + "/mesh.ply\""), std::string::npos);
  EXPECT_EQ(Get("/index.json").body.rfind("{\"format\": 1", 0), 0u);
  EXPECT_EQ(Get("/three/three.min.js").status, 200);
  const std::string mesh = "/out/" + f_.instants[0] + "/mesh.ply";
  EXPECT_EQ(Get(mesh).body, io::ReadFileBytes(f_.out / f_.instants[0] / "mesh.ply"));
  const std::string frame = "frames/" + f_.instants[0] + "/c1.png";
  EXPECT_EQ(Get("/take/" + frame).body, io::ReadFileBytes(f_.take / frame));
  EXPECT_EQ(Get("/out/" + f_.instants[0] + "/none.ply").status, 404);
}

TEST_F(ServerTest, NewInstantsAppearWhenTheIndexIsReloaded) {
  EXPECT_EQ(Get("/index.json").body.find("out/" + f_.instants[2] + "/mesh.ply"), std::string::npos);
  fs::create_directories(f_.out / f_.instants[2]);
  io::WritePly(f_.out / f_.instants[2] / "mesh.ply", testing::Square(100, 0));
  EXPECT_NE(Get("/index.json").body.find("out/" + f_.instants[2] + "/mesh.ply"), std::string::npos);
}

TEST_F(ServerTest, ServesPerVertexErrorsAndDepthPreviews) {
  const auto err = Get("/derived/error/" + f_.instants[0] + "/fused.f32");
  ASSERT_EQ(err.status, 200);
  ASSERT_EQ(err.body.size(), 4u * 4);  // four vertices, float32
  float d[4];
  std::memcpy(d, err.body.data(), sizeof d);
  for (const float v : d) EXPECT_NEAR(v, 7.0, 1e-4);  // the square 7 mm above truth
  const auto depth = Get("/derived/depth/" + f_.instants[0] + "/c0.png");
  EXPECT_EQ(depth.status, 200);
  EXPECT_EQ(depth.body.substr(1, 3), "PNG");
  // No truth for the second instant: 422 with the reason.
  const auto none = Get("/derived/error/" + f_.instants[1] + "/fused.f32");
  EXPECT_EQ(none.status, 422);
  EXPECT_NE(none.body.find("no truth mesh"), std::string::npos);
  EXPECT_EQ(Get("/derived/depth/" + f_.instants[0] + "/c9.png").status, 404);
}

TEST_F(ServerTest, CorruptMeshGives422NamingTheFile) {
  io::WriteFileAtomically(f_.out / f_.instants[0] / "mesh_decimated.ply", "ply\ngarbage");
  const auto r = Get("/derived/error/" + f_.instants[0] + "/decimated.f32");
  EXPECT_EQ(r.status, 422);
  EXPECT_NE(r.body.find("mesh_decimated.ply"), std::string::npos);
}

TEST_F(ServerTest, RefusesEveryWayOutOfTheServedFolders) {
  const std::string i0 = f_.instants[0];
  const char* attempts[] = {
      "/out/../secret.txt",
      "/out/%2e%2e/secret.txt",
      "/out/%2E%2E/secret.txt",
      "/out/..%2fsecret.txt",
      "/out/..%2Fsecret.txt",
      "/out/%2e%2e%2fsecret.txt",
      "/out/%252e%252e/secret.txt",
      "/out/%252e%252e%252fsecret.txt",
      "/out/..%5csecret.txt",
      "/out//etc/passwd",
      "/out/%2fetc%2fpasswd",
      "/take/../secret.txt",
      "/take/frames/../../secret.txt",
      "/take/%2e%2e/%2e%2e/etc/passwd",
      "/../secret.txt",
      "/%2e%2e/secret.txt",
      "/..%2f..%2f..%2fetc%2fpasswd",
      "/three/../../secret.txt",
      "/etc/passwd",
      "//etc/passwd",
      "/derived/depth/../../secret.txt",
  };
  for (const char* target : attempts) {
    const auto r = Get(target);
    EXPECT_NE(r.status, 200) << target;
    EXPECT_NE(r.status, 0) << target << ": no reply";
    EXPECT_EQ(r.body.find(kSecret), std::string::npos) << target;
    EXPECT_EQ(r.body.find("root:"), std::string::npos) << target;
  }
  // The refusals say why.
  EXPECT_EQ(Get("/out/%2e%2e/secret.txt").status, 403);
  EXPECT_NE(Get("/out/%252e%252e/secret.txt").body.find("percent"), std::string::npos);
  EXPECT_NE(Get("/out//etc/passwd").body.find("absolute"), std::string::npos);
  const auto link = Get("/out/" + i0 + "/escape.ply");
  EXPECT_EQ(link.status, 403);
  EXPECT_NE(link.body.find("outside the served folder"), std::string::npos);
  EXPECT_EQ(Get("/out/" + i0).status, 403);  // a folder is not a file
}

TEST(Server, PortInUseNamesTheAddress) {
  dome::testing::TempDir tmp;
  const auto f = testing::MakeViewFixture(tmp.path());
  ServerOptions o;
  o.port = 0;
  ViewerServer first(f.out, f.take, kAssets, o);
  o.port = first.Bind();
  ViewerServer second(f.out, f.take, kAssets, o);
  dome::testing::ExpectInputError([&] { second.Bind(); },
                                  {"--port " + std::to_string(o.port), "cannot listen"});
}

}  // namespace
}  // namespace dome::view
