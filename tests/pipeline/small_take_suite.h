// A test suite over one small synthetic take (`dome synth --preset small --instants 1`),
// made once per suite in a temporary folder: TakeDir() is TEMP/take.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>

#include "testing/run_command.h"
#include "testing/temp_dir.h"

namespace dome::pipeline {

class SmallTakeSuite : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new dome::testing::TempDir;
    const auto synth = dome::testing::RunDomeBinary("synth --preset small --instants 1 --out " +
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

}  // namespace dome::pipeline
