#include "geometry/parse_util.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "geometry_test_util.h"

namespace dome::geometry::internal {
namespace {

using testing::ExpectInputError;

TEST(ParseUtil, FormatDoubleRoundTripsAndStaysShort) {
  EXPECT_EQ(FormatDouble(-512.3), "-512.3");
  EXPECT_EQ(FormatDouble(0.023), "0.023");
  EXPECT_EQ(FormatDouble(0.0), "0");
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> mantissa(-1.0, 1.0);
  std::uniform_int_distribution<int> exponent(-300, 300);
  for (int i = 0; i < 10000; ++i) {
    const double value = std::ldexp(mantissa(rng), exponent(rng));
    EXPECT_EQ(ParseDouble(FormatDouble(value), "x"), value);
  }
}

TEST(ParseUtil, ParseDoubleIsStrict) {
  EXPECT_EQ(ParseDouble(" 2.5\t", "x"), 2.5);
  EXPECT_EQ(ParseDouble("+1e-3", "x"), 1e-3);
  for (const char* bad : {"", " ", "nan", "inf", "-inf", "1e999", "1.5x", "1,5", "one", "2 3"}) {
    ExpectInputError([&] { ParseDouble(bad, "file.txt: field"); },
                     {"file.txt: field", "finite number"});
  }
}

TEST(ParseUtil, ParseIntIsStrict) {
  EXPECT_EQ(ParseInt(" 640 ", "x"), 640);
  EXPECT_EQ(ParseInt("-3", "x"), -3);
  EXPECT_EQ(ParseInt("+7", "x"), 7);
  for (const char* bad : {"", "6.5", "1e3", "99999999999", "x", "1 2"}) {
    ExpectInputError([&] { ParseInt(bad, "file.txt: n"); }, {"file.txt: n", "integer"});
  }
}

TEST(ParseUtil, Lines) {
  const std::vector<std::string> lines = SplitLines("a\r\nb\n\nc");
  ASSERT_EQ(lines.size(), 4u);
  EXPECT_EQ(lines[0], "a");
  EXPECT_EQ(lines[1], "b");
  EXPECT_EQ(lines[2], "");
  EXPECT_EQ(lines[3], "c");
  EXPECT_EQ(SplitWhitespace(" a\tb  c\n").size(), 3u);
  EXPECT_EQ(Trim("  x y \t"), "x y");
}

TEST(ParseUtil, RequireNearRotationProjects) {
  Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
  r(0, 1) = 2e-6;
  const Eigen::Matrix3d fixed = RequireNearRotation(r, 1e-5, "f");
  EXPECT_LT((fixed * fixed.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_LT((fixed - r).cwiseAbs().maxCoeff(), 2e-6);
  ExpectInputError([&] { RequireNearRotation(r, 1e-6, "f: R"); }, {"f: R", "orthonormal"});
  ExpectInputError([&] { RequireNearRotation(-Eigen::Matrix3d::Identity(), 1e-6, "f: R"); },
                   {"f: R", "determinant"});
}

}  // namespace
}  // namespace dome::geometry::internal
