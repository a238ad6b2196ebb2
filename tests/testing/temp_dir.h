// Test helper: a fresh folder under the system temp folder, named after the running
// test, removed with everything in it when the object goes away.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <random>
#include <string>

namespace dome::testing {

class TempDir {
 public:
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    std::string test = info == nullptr ? std::string("global")
                                       : std::string(info->test_suite_name()) + "_" + info->name();
    for (char& c : test) {
      if (c == '/') c = '_';  // parameterized tests are named "Prefix/Suite"
    }
    path_ = std::filesystem::temp_directory_path() /
            ("dome_test_" + std::to_string(::getpid()) + "_" + test + "_" +
             std::to_string(std::random_device{}()));
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    // Undo chmods of permission tests so removal succeeds.
    std::filesystem::permissions(path_, std::filesystem::perms::owner_all, ec);
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }
  std::string File(const std::string& name) const { return (path_ / name).string(); }

 private:
  std::filesystem::path path_;
};

}  // namespace dome::testing
