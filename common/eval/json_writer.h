// A minimal writer for flat JSON objects (the evaluation reports).
//
// Output is one line in the style of Python's json.dumps -- {"key": value, ...} with
// keys in insertion order -- so reports diff cleanly against eval_cloud.py's. Numbers
// are written in the shortest form that reads back to the same double; NaN and
// infinities, which JSON cannot hold, are written as null.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace dome::eval {

class JsonObjectWriter {
 public:
  JsonObjectWriter& AddNumber(std::string_view key, double value);
  JsonObjectWriter& AddInt(std::string_view key, int64_t value);
  JsonObjectWriter& AddString(std::string_view key, std::string_view value);
  JsonObjectWriter& AddBool(std::string_view key, bool value);
  JsonObjectWriter& AddNull(std::string_view key);
  JsonObjectWriter& AddNumbers(std::string_view key, const std::vector<double>& values);

  // The object, e.g. {"a": 1, "b": null}.
  std::string str() const { return "{" + body_ + "}"; }

 private:
  void Key(std::string_view key);
  std::string body_;
};

// `s` as a JSON string literal, quotes included.
std::string JsonQuote(std::string_view s);
// Shortest round-trip decimal form of `value`; "null" when not finite.
std::string JsonNumber(double value);
// Python's '%g' of `value` (0.5 -> "0.5", 1.0 -> "1"): for keys like "precision@1mm".
std::string FormatG(double value);

}  // namespace dome::eval
