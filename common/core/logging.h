// Logging set-up shared by every dome executable (spdlog, to stderr).
#pragma once

#include <string>

namespace dome::core {

// `level`: one of trace, debug, info, warn, error, off. Throws InputError naming
// `flag` for anything else.
void SetUpLogging(const std::string& level, const std::string& flag = "--log-level");

}  // namespace dome::core
