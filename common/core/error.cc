#include "core/error.h"

#include <cstdio>
#include <cstdlib>

namespace dome::core {

InputError::InputError(std::string where, const std::string& what)
    : std::runtime_error(where.empty() ? what : where + ": " + what), where_(std::move(where)) {}

InputError InputError::Under(const std::string& outer) const {
  // what() is "where: message"; keep only the message.
  std::string message = what();
  const std::string prefix = where_ + ": ";
  if (!where_.empty() && message.rfind(prefix, 0) == 0) message = message.substr(prefix.size());
  return InputError(outer + ": " + where_, message);
}

void CheckFailed(const char* file, int line, const char* expr, const std::string& msg) {
  std::fprintf(stderr, "dome: internal error at %s:%d: check '%s' failed: %s\n", file, line, expr,
               msg.c_str());
  std::abort();
}

}  // namespace dome::core
