// Error reporting for dome.
//
// Two kinds of failure, handled differently (STYLE.md, convention 4):
//  * Bad input or bad configuration -- a file, a JSON field, a command-line flag, a
//    network peer -- throws dome::core::InputError. Its message always names *where*
//    (file path, "file: field", "peer tcp://...") and *what* was expected.
//    Writes this process cannot make throw its subclass StorageError.
//  * Programmer errors (broken invariants) abort via DOME_CHECK with file:line.
//    DOME_CHECK is never used on data that comes from outside the process.
#pragma once

#include <stdexcept>
#include <string>

namespace dome::core {

class InputError : public std::runtime_error {
 public:
  // `where`: the file, "file: field", flag or peer at fault. `what`: what was wrong
  // and what was expected instead.
  InputError(std::string where, const std::string& what);

  const std::string& where() const { return where_; }

  // The same error placed under `outer` (a file or message name): where becomes
  // "outer: where", the message is not repeated.
  InputError Under(const std::string& outer) const;

 private:
  std::string where_;
};

// A file this process writes could not be written (disk full, read-only or missing
// folder, quota): the storage's fault, not the data's. An InputError, so every
// handler of bad input reports it; the master tells it apart to fail a session on it
// rather than re-queue the job whose outputs it was writing (a full disk fails every
// worker's result the same way). `where` is the file.
class StorageError : public InputError {
 public:
  using InputError::InputError;
};

// Throws InputError(where, what) unless `condition` holds.
inline void Require(bool condition, const std::string& where, const std::string& what) {
  if (!condition) throw InputError(where, what);
}

[[noreturn]] void CheckFailed(const char* file, int line, const char* expr, const std::string& msg);

}  // namespace dome::core

#define DOME_CHECK(expr, msg)                                               \
  do {                                                                      \
    if (!(expr)) ::dome::core::CheckFailed(__FILE__, __LINE__, #expr, msg); \
  } while (false)
