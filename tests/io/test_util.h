// Helpers shared by the io and eval tests (the temporary folder and the InputError
// check come from tests/testing/).
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>

#include "core/error.h"
#include "testing/expect_error.h"
#include "testing/temp_dir.h"

namespace dome::testing {

inline bool RunningAsRoot() { return ::geteuid() == 0; }

}  // namespace dome::testing
