// A test suite over one small synthetic take (`dome synth --preset small --instants N`,
// N = 1 for SmallTakeSuite), made once per suite in a temporary folder: TakeDir() is
// TEMP/take.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "testing/run_command.h"
#include "testing/temp_dir.h"

namespace dome::pipeline {

template <int kInstants>
class SmallTakeSuiteOf : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new dome::testing::TempDir;
    const auto synth = dome::testing::RunDomeBinary(
        "synth --preset small --instants " + std::to_string(kInstants) + " --out " +
        TakeDir().string());
    ASSERT_EQ(synth.exit_code, 0) << synth.output;
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static std::filesystem::path TakeDir() { return *dir_ / "take"; }

 private:
  static inline dome::testing::TempDir* dir_ = nullptr;
};

using SmallTakeSuite = SmallTakeSuiteOf<1>;

}  // namespace dome::pipeline
