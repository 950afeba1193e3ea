#include "formats/input_error.h"

#include <algorithm>

namespace rs {

std::string InputLocation::ToString() const {
  std::string s = path.empty() ? std::string("<input>") : path;
  if (line >= 0) {
    s += ":" + std::to_string(line);
    if (column >= 0) s += ":" + std::to_string(column);
  } else if (byte_offset >= 0) {
    s += " @ byte " + std::to_string(byte_offset);
  }
  return s;
}

InputError::InputError(InputLocation where, const std::string& message)
    : std::runtime_error(where.ToString() + ": " + message), where_(std::move(where)), message_(message) {}

std::string InputProblem::ToString() const {
  return std::string(severity == Severity::kError ? "error: " : "warning: ") + where.ToString() + ": " + message;
}

void ProblemList::Error(InputLocation where, std::string message) {
  items_.push_back({InputProblem::Severity::kError, std::move(where), std::move(message)});
}

void ProblemList::Warning(InputLocation where, std::string message) {
  items_.push_back({InputProblem::Severity::kWarning, std::move(where), std::move(message)});
}

int ProblemList::ErrorCount() const {
  return static_cast<int>(std::count_if(items_.begin(), items_.end(), [](const InputProblem& p) {
    return p.severity == InputProblem::Severity::kError;
  }));
}

int ProblemList::WarningCount() const { return static_cast<int>(items_.size()) - ErrorCount(); }

}  // namespace rs
