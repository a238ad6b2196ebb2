#include "core/json.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace dome::core {
namespace {

TEST(Json, OneLineInPythonStyle) {
  const Json j = {{"name", "a \"b\"\\c\n\x01"},
                  {"n", -42},
                  {"x", 0.1},
                  {"nan", std::nan("")},
                  {"inf", std::numeric_limits<double>::infinity()},
                  {"ok", true},
                  {"none", nullptr},
                  {"v", {1.0, 2.5, -1e-7}},
                  {"nested", {{"z", Json::array()}, {"a", Json::object()}}}};
  // The same text as Python's json.dumps of the same dict (NaN and inf as null).
  EXPECT_EQ(DumpJson(j),
            R"({"name": "a \"b\"\\c\n\u0001", "n": -42, "x": 0.1, "nan": null, "inf": null, )"
            R"("ok": true, "none": null, "v": [1.0, 2.5, -1e-07], "nested": {"z": [], "a": {}}})");
  EXPECT_EQ(DumpJson(Json::object()), "{}");
}

TEST(Json, InvalidUtf8IsReplacedNotThrown) {
  // Paths are user input: a Latin-1 byte must not make a report unwritable.
  EXPECT_EQ(DumpJson(Json{{"take", std::string("caf\xe9")}}), "{\"take\": \"caf\xef\xbf\xbd\"}");
  EXPECT_EQ(DumpJson(Json{{"take", std::string("caf\xe9")}}, 1),
            "{\n \"take\": \"caf\xef\xbf\xbd\"\n}");
}

TEST(Json, DoublesRoundTrip) {
  const double v = 0.123456789012345678;
  EXPECT_EQ(std::stod(DumpJson(Json(v))), v);
}

TEST(Json, FloatsAsNineDigitsOrIntegers) {
  EXPECT_EQ(DumpJson(FloatJson(0.1f)), "0.100000001");
  EXPECT_EQ(DumpJson(FloatJson(-250.0f)), "-250");
  EXPECT_EQ(DumpJson(FloatJson(1234.5f)), "1234.5");
  EXPECT_EQ(DumpJson(FloatJson(std::numeric_limits<float>::quiet_NaN())), "null");
  // 9 digits read back to the same float.
  const float f = 1.0f / 3.0f;
  EXPECT_EQ(float(FloatJson(f).get<double>()), f);
}

}  // namespace
}  // namespace dome::core
