#include "view/path_safety.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "testing/temp_dir.h"

namespace dome::view {
namespace {

namespace fs = std::filesystem;

TEST(PathSafety, AcceptsPlainRelativePaths) {
  for (const char* p : {"00-00-01-00/mesh.ply", "index.html", "three/three.min.js", "a.b/c..d"})
    EXPECT_TRUE(IsSafeRelativePath(p)) << p;
}

TEST(PathSafety, RefusesTraversalAbsoluteAndEncodedShapes) {
  const std::pair<const char*, const char*> cases[] = {
      {"", "empty"},
      {"/etc/passwd", "absolute"},
      {"../secret", "'..'"},
      {"a/../../secret", "'..'"},
      {"a/..", "'..'"},
      {"./a", "'.'"},
      {"a//b", "empty path segment"},
      {"a/", "empty path segment"},
      {"..\\secret", "backslash"},
      {"C:/secret", "':'"},
      {"%2e%2e/secret", "percent"},
      {"a%2f..%2fsecret", "percent"},
      {"a\nb", "control"},
  };
  for (const auto& [path, reason] : cases) {
    std::string why;
    EXPECT_FALSE(IsSafeRelativePath(path, &why)) << path;
    EXPECT_NE(why.find(reason), std::string::npos) << path << ": " << why;
  }
}

class ResolveTest : public ::testing::Test {
 protected:
  void SetUp() override {
    fs::create_directories(root() / "sub");
    fs::create_directories(tmp_ / "root-evil");
    std::ofstream(root() / "sub" / "file.txt") << "inside";
    std::ofstream(tmp_ / "secret.txt") << "secret";
    std::ofstream(tmp_ / "root-evil" / "file.txt") << "sibling";
  }
  fs::path root() const { return tmp_ / "root"; }
  dome::testing::TempDir tmp_;
};

TEST_F(ResolveTest, FileInsideResolvesToItsCanonicalPath) {
  const ResolvedPath r = ResolveUnder(root(), "sub/file.txt");
  ASSERT_TRUE(r.ok) << r.why;
  EXPECT_EQ(r.path, fs::canonical(root() / "sub" / "file.txt"));
}

TEST_F(ResolveTest, MissingFileAndFolderAreRefused) {
  EXPECT_EQ(ResolveUnder(root(), "sub/none.txt").why, "no such file");
  EXPECT_EQ(ResolveUnder(root(), "sub").why, "not a regular file");
}

TEST_F(ResolveTest, SymlinksOutOfTheRootAreRefused) {
  fs::create_symlink(tmp_ / "secret.txt", root() / "sub" / "link.txt");
  fs::create_directory_symlink(tmp_.path(), root() / "up");
  // "root-evil" shares the root's name as a prefix: a string prefix test would pass it.
  fs::create_symlink(tmp_ / "root-evil" / "file.txt", root() / "evil.txt");
  for (const char* p : {"sub/link.txt", "up/secret.txt", "evil.txt"}) {
    const ResolvedPath r = ResolveUnder(root(), p);
    EXPECT_FALSE(r.ok) << p;
    EXPECT_EQ(r.why, "resolves outside the served folder") << p;
  }
}

TEST_F(ResolveTest, SymlinkInsideTheRootIsFollowed) {
  fs::create_symlink(root() / "sub" / "file.txt", root() / "alias.txt");
  const ResolvedPath r = ResolveUnder(root(), "alias.txt");
  ASSERT_TRUE(r.ok) << r.why;
  EXPECT_EQ(r.path, fs::canonical(root() / "sub" / "file.txt"));
}

}  // namespace
}  // namespace dome::view
