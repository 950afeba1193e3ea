#include "formats/trajectory/timestamp_text.h"

#include <limits>

namespace rs {

namespace {

bool IsDigit(char c) { return c >= '0' && c <= '9'; }

}  // namespace

SecondsParseResult ParseSecondsToNs(std::string_view s) {
  SecondsParseResult bad;  // kSyntax by default
  size_t i = 0;
  bool negative = false;
  if (i < s.size() && (s[i] == '+' || s[i] == '-')) negative = s[i++] == '-';

  // Mantissa digits, integer part then fraction; only their positions matter, not their count.
  const size_t mantissa_begin = i;
  size_t int_digits = 0;
  while (i < s.size() && IsDigit(s[i])) ++i, ++int_digits;
  size_t frac_digits = 0;
  if (i < s.size() && s[i] == '.') {
    ++i;
    while (i < s.size() && IsDigit(s[i])) ++i, ++frac_digits;
  }
  if (int_digits + frac_digits == 0) return bad;
  const size_t mantissa_end = i;

  // Exponent, saturated: anything beyond +-1e6 is already all-overflow or all-rounded-away.
  int64_t exponent = 0;
  if (i < s.size() && (s[i] == 'e' || s[i] == 'E')) {
    ++i;
    bool exp_negative = false;
    if (i < s.size() && (s[i] == '+' || s[i] == '-')) exp_negative = s[i++] == '-';
    if (i == s.size() || !IsDigit(s[i])) return bad;
    while (i < s.size() && IsDigit(s[i])) {
      if (exponent < 1000000) exponent = exponent * 10 + (s[i] - '0');
      ++i;
    }
    if (exp_negative) exponent = -exponent;
  }
  if (i != s.size()) return bad;

  // Digit number d (0-based over all mantissa digits) has place value 10^(keep - 1 - d) ns, so the
  // first `keep` digits are whole nanoseconds and digit `keep` decides the rounding.
  const int64_t keep = static_cast<int64_t>(int_digits) + exponent + 9;
  constexpr uint64_t kLimit = static_cast<uint64_t>(std::numeric_limits<int64_t>::max()) + 1;  // |INT64_MIN|
  uint64_t magnitude = 0;
  int64_t d = 0;
  bool round_up = false;
  SecondsParseResult overflow;
  overflow.error = SecondsParseError::kOverflow;
  for (size_t k = mantissa_begin; k < mantissa_end; ++k) {
    if (s[k] == '.') continue;
    const int digit = s[k] - '0';
    if (d < keep) {
      if (magnitude > (kLimit - digit) / 10) return overflow;
      magnitude = magnitude * 10 + digit;
    } else if (d == keep) {
      round_up = digit >= 5;
      break;
    } else {
      break;
    }
    ++d;
  }
  // Trailing zeros implied by a positive exponent beyond the written digits.
  for (int64_t z = static_cast<int64_t>(int_digits + frac_digits); z < keep && magnitude != 0; ++z) {
    if (magnitude > kLimit / 10) return overflow;
    magnitude *= 10;
  }
  if (round_up) {
    if (magnitude >= kLimit) return overflow;
    ++magnitude;
  }
  if (magnitude > kLimit || (!negative && magnitude == kLimit)) return overflow;
  SecondsParseResult ok;
  ok.t_ns = negative ? static_cast<int64_t>(0 - magnitude) : static_cast<int64_t>(magnitude);
  return ok;
}

std::string FormatNsAsSeconds(int64_t t_ns) {
  // Magnitude in uint64 so INT64_MIN has no positive counterpart problem.
  const bool negative = t_ns < 0;
  const uint64_t magnitude = negative ? 0 - static_cast<uint64_t>(t_ns) : static_cast<uint64_t>(t_ns);
  std::string frac = std::to_string(magnitude % 1000000000ULL);
  frac.insert(0, 9 - frac.size(), '0');
  return (negative ? "-" : "") + std::to_string(magnitude / 1000000000ULL) + "." + frac;
}

}  // namespace rs
