// The one JSON writer of dome's reports, indexes and JSON lines: documents are built as
// nlohmann::ordered_json (keys keep insertion order) and printed here.
//
// Format: `DumpJson(j)` prints one line in the style of Python's json.dumps, with ", "
// and ": " separators, so reports diff cleanly against the Python evaluator's;
// `DumpJson(j, indent)` with indent >= 0 prints nlohmann's indented form. Strings are
// escaped by nlohmann (invalid UTF-8 replaced by U+FFFD, never a throw: a take path is
// user input). Numbers: integers as integers, doubles in the shortest form that reads
// back to the same double; NaN and infinities, which JSON cannot hold, print as null.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace dome::core {

using Json = nlohmann::ordered_json;

std::string DumpJson(const Json& j, int indent = -1);

// `j` as one line on standard output, flushed: the JSON lines of benchmarks and commands.
void PrintJsonLine(const Json& j);

// A float for JSON: its value to 9 significant digits (enough to read back the same
// float, without the binary tail a double conversion would print), or an integer when
// it is one. Used for glTF accessor bounds.
Json FloatJson(float value);

}  // namespace dome::core
