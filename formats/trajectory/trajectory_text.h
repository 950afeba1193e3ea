#pragma once
// Line and field scanning shared by the trajectory readers (internal to rs_trajectory_io).
// Keeps the 1-based line and column of every field so errors point into the input.
// Not formats/flight_log/flight_log_text.h: this throws InputError at the first bad field.

#include <cstdint>
#include <iosfwd>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace rs::trajectory_text {

/// Longest accepted line; longer lines are an error instead of an unbounded allocation.
inline constexpr size_t kMaxLineBytes = 1 << 16;

/// One field of a line and the 1-based column it starts at.
struct Field {
  std::string_view text;
  int64_t column = 0;
};

/// Reads lines with a bounded length, counting them; strips a trailing '\r'.
class LineReader {
 public:
  LineReader(std::istream& in, std::string path) : in_(in), path_(std::move(path)) {}
  /// False at end of input; throws InputError on an over-long line or a read failure.
  bool Next(std::string* line);
  int64_t line_number() const { return line_number_; }
  const std::string& path() const { return path_; }

 private:
  std::istream& in_;
  std::string path_;
  int64_t line_number_ = 0;
};

/// Splits on any of `separators`, dropping empty fields (so runs of spaces are one separator).
std::vector<Field> SplitFields(std::string_view line, std::string_view separators);

/// Splits on ',' keeping empty fields (an empty CSV cell is an error, not a skipped column);
/// spaces around each cell are trimmed.
std::vector<Field> SplitCsv(std::string_view line);

/// True for lines that carry no data: empty, blanks only, or starting with '#' after blanks.
bool IsBlankOrComment(std::string_view line);

/// A finite double or InputError at path:line:column ("non-finite value", "not a number").
double ParseFinite(const Field& f, const std::string& path, int64_t line, const char* what);

/// Seconds text to exact ns (see ParseSecondsToNs) or InputError.
int64_t ParseSecondsField(const Field& f, const std::string& path, int64_t line);

/// A plain decimal integer of nanoseconds (ASL/EuRoC) or InputError.
int64_t ParseNsField(const Field& f, const std::string& path, int64_t line);

/// Unit quaternion from (w, x, y, z): normalised if ||q| - 1| <= kQuaternionNormTolerance, else InputError
/// at the column of the first quaternion field.
Eigen::Quaterniond CheckedQuaternion(double w, double x, double y, double z, const std::string& path, int64_t line,
                                     int64_t column);
inline constexpr double kQuaternionNormTolerance = 1e-3;

/// Rotation from a 3x3 matrix that must be a rotation up to rounding of the printed digits:
/// ||R^T R - I||_F <= kRotationTolerance and det > 0; returned re-orthonormalised, else InputError.
Eigen::Matrix3d CheckedRotation(const Eigen::Matrix3d& R, const std::string& path, int64_t line, int64_t column);
inline constexpr double kRotationTolerance = 1e-3;

/// Throws InputError when t_ns < previous. Equal times are accepted: real SLAM outputs repeat a stamp
/// (evo's V102.txt has 4), and association keeps only the first pose of such a run.
void CheckNotDecreasing(int64_t previous_t_ns, int64_t t_ns, bool has_previous, const std::string& path, int64_t line,
                        int64_t column);

}  // namespace rs::trajectory_text
