#include "formats/trajectory/trajectory_text.h"

#include <charconv>
#include <cmath>
#include <istream>

#include <Eigen/SVD>
#include <fmt/format.h>

#include "formats/input_error.h"
#include "formats/trajectory/timestamp_text.h"

namespace rs::trajectory_text {

bool LineReader::Next(std::string* line) {
  line->clear();
  char c;
  bool any = false;
  while (in_.get(c)) {
    any = true;
    if (c == '\n') break;
    if (line->size() >= kMaxLineBytes) {
      throw InputError(InputLocation::Line(path_, line_number_ + 1),
                       fmt::format("line longer than {} bytes", kMaxLineBytes));
    }
    line->push_back(c);
  }
  if (in_.bad()) throw InputError(InputLocation::Line(path_, line_number_ + 1), "read error");
  if (!any) return false;
  ++line_number_;
  if (!line->empty() && line->back() == '\r') line->pop_back();
  return true;
}

std::vector<Field> SplitFields(std::string_view line, std::string_view separators) {
  std::vector<Field> fields;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && separators.find(line[i]) != std::string_view::npos) ++i;
    if (i == line.size()) break;
    const size_t begin = i;
    while (i < line.size() && separators.find(line[i]) == std::string_view::npos) ++i;
    fields.push_back({line.substr(begin, i - begin), static_cast<int64_t>(begin) + 1});
  }
  return fields;
}

std::vector<Field> SplitCsv(std::string_view line) {
  std::vector<Field> fields;
  size_t begin = 0;
  while (true) {
    size_t end = line.find(',', begin);
    if (end == std::string_view::npos) end = line.size();
    size_t b = begin, e = end;
    while (b < e && (line[b] == ' ' || line[b] == '\t')) ++b;
    while (e > b && (line[e - 1] == ' ' || line[e - 1] == '\t')) --e;
    fields.push_back({line.substr(b, e - b), static_cast<int64_t>(b) + 1});
    if (end == line.size()) break;
    begin = end + 1;
  }
  return fields;
}

bool IsBlankOrComment(std::string_view line) {
  for (char c : line) {
    if (c == ' ' || c == '\t') continue;
    return c == '#';
  }
  return true;
}

double ParseFinite(const Field& f, const std::string& path, int64_t line, const char* what) {
  std::string_view t = f.text;
  if (!t.empty() && t.front() == '+') t.remove_prefix(1);  // from_chars rejects a leading '+'
  double v = 0;
  const auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
  if (t.empty() || end != t.data() + t.size() || ec == std::errc::invalid_argument) {
    throw InputError(InputLocation::Line(path, line, f.column), fmt::format("{}: '{}' is not a number", what, f.text));
  }
  if (ec == std::errc::result_out_of_range || !std::isfinite(v)) {
    throw InputError(InputLocation::Line(path, line, f.column), fmt::format("{}: non-finite value '{}'", what, f.text));
  }
  return v;
}

int64_t ParseSecondsField(const Field& f, const std::string& path, int64_t line) {
  const SecondsParseResult r = ParseSecondsToNs(f.text);
  if (r.t_ns) return *r.t_ns;
  throw InputError(InputLocation::Line(path, line, f.column),
                   r.error == SecondsParseError::kOverflow
                       ? fmt::format("timestamp '{}' s does not fit int64 nanoseconds", f.text)
                       : fmt::format("timestamp '{}' is not a decimal number of seconds", f.text));
}

int64_t ParseNsField(const Field& f, const std::string& path, int64_t line) {
  int64_t v = 0;
  const auto [end, ec] = std::from_chars(f.text.data(), f.text.data() + f.text.size(), v);
  if (f.text.empty() || end != f.text.data() + f.text.size() || ec != std::errc()) {
    throw InputError(InputLocation::Line(path, line, f.column),
                     fmt::format("timestamp '{}' is not an integer number of nanoseconds", f.text));
  }
  return v;
}

Eigen::Quaterniond CheckedQuaternion(double w, double x, double y, double z, const std::string& path, int64_t line,
                                     int64_t column) {
  Eigen::Quaterniond q(w, x, y, z);
  const double norm = q.norm();
  if (!(std::abs(norm - 1.0) <= kQuaternionNormTolerance)) {
    throw InputError(
        InputLocation::Line(path, line, column),
        fmt::format("quaternion norm {:.6g} is not 1 (allowed |norm - 1| <= {})", norm, kQuaternionNormTolerance));
  }
  q.coeffs() /= norm;
  return q;
}

Eigen::Matrix3d CheckedRotation(const Eigen::Matrix3d& R, const std::string& path, int64_t line, int64_t column) {
  const double orthogonality = (R.transpose() * R - Eigen::Matrix3d::Identity()).norm();
  if (!(orthogonality <= kRotationTolerance) || !(R.determinant() > 0)) {
    throw InputError(InputLocation::Line(path, line, column),
                     fmt::format("not a rotation matrix: ||R^T R - I|| = {:.3g} (allowed {}), det = {:.6g}",
                                 orthogonality, kRotationTolerance, R.determinant()));
  }
  // Nearest rotation in the Frobenius sense; the printed digits leave R slightly off SO(3).
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
  return svd.matrixU() * svd.matrixV().transpose();
}

void CheckNotDecreasing(int64_t previous_t_ns, int64_t t_ns, bool has_previous, const std::string& path, int64_t line,
                        int64_t column) {
  if (has_previous && t_ns < previous_t_ns) {
    throw InputError(InputLocation::Line(path, line, column),
                     fmt::format("timestamp {} is before the previous one ({}); times must not decrease",
                                 FormatNsAsSeconds(t_ns), FormatNsAsSeconds(previous_t_ns)));
  }
}

}  // namespace rs::trajectory_text
