#include "eval/json_writer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace dome::eval {
namespace {

TEST(JsonObjectWriter, FlatObjectInPythonStyle) {
  JsonObjectWriter json;
  json.AddString("name", "a \"b\"\\c\n\x01")
      .AddInt("n", -42)
      .AddNumber("x", 0.1)
      .AddNumber("nan", std::nan(""))
      .AddNumber("inf", std::numeric_limits<double>::infinity())
      .AddBool("ok", true)
      .AddNull("none")
      .AddNumbers("v", {1.0, 2.5, -1e-7});
  EXPECT_EQ(json.str(),
            R"({"name": "a \"b\"\\c\n\u0001", "n": -42, "x": 0.1, "nan": null, "inf": null, )"
            R"("ok": true, "none": null, "v": [1, 2.5, -1e-07]})");
  EXPECT_EQ(JsonObjectWriter().str(), "{}");
}

TEST(FormatG, MatchesPythonPercentG) {
  EXPECT_EQ(FormatG(0.5), "0.5");
  EXPECT_EQ(FormatG(1.0), "1");
  EXPECT_EQ(FormatG(2.0), "2");
  EXPECT_EQ(FormatG(0.25), "0.25");
  EXPECT_EQ(FormatG(10.0), "10");
}

TEST(JsonNumber, RoundTrips) {
  const double v = 0.123456789012345678;
  EXPECT_EQ(std::stod(JsonNumber(v)), v);
}

}  // namespace
}  // namespace dome::eval
