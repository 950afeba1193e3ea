#pragma once
// Errors about user input (files, logs, images, calibration): they carry the
// input's own location, never the parser's source line.

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace rs {

/// Where in an input a problem sits. Unknown parts are -1.
struct InputLocation {
  std::string path;          ///< file (or folder) the problem is in
  int64_t line = -1;         ///< 1-based line for text inputs
  int64_t column = -1;       ///< 1-based column for text inputs
  int64_t byte_offset = -1;  ///< 0-based byte offset for binary inputs

  static InputLocation File(std::string path) { return {std::move(path)}; }
  static InputLocation Line(std::string path, int64_t line, int64_t column = -1) {
    return {std::move(path), line, column, -1};
  }
  static InputLocation Byte(std::string path, int64_t offset) { return {std::move(path), -1, -1, offset}; }

  /// "log.csv:118", "log.csv:118:7", "log.ulg @ byte 48213" or "log.csv".
  std::string ToString() const;
};

/// Bad input: the file is missing, unreadable, malformed or implausible.
/// what() is "<location>: <message>".
class InputError : public std::runtime_error {
 public:
  InputError(InputLocation where, const std::string& message);
  const InputLocation& where() const { return where_; }
  const std::string& message() const { return message_; }

 private:
  InputLocation where_;
  std::string message_;
};

/// One problem found while checking inputs; validation collects all of them
/// instead of stopping at the first.
struct InputProblem {
  enum class Severity { kWarning, kError };
  Severity severity = Severity::kError;
  InputLocation where;
  std::string message;
  std::string ToString() const;  // "error: <location>: <message>"
};

/// Problems collected across a validation pass.
class ProblemList {
 public:
  void Error(InputLocation where, std::string message);
  void Warning(InputLocation where, std::string message);
  void Add(const InputError& e) { Error(e.where(), e.message()); }
  const std::vector<InputProblem>& items() const { return items_; }
  int ErrorCount() const;
  int WarningCount() const;
  bool HasErrors() const { return ErrorCount() > 0; }

 private:
  std::vector<InputProblem> items_;
};

}  // namespace rs
