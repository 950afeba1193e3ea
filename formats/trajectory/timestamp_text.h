#pragma once
// Exact conversion between decimal seconds text ("1403715529.112143517", "1.037359e-01") and int64
// nanoseconds. Going through double would lose the last digits of epoch-scale times (a double
// keeps ~16 significant digits, an epoch time in ns needs 19), which breaks timestamp association.

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace rs {

/// Why ParseSecondsToNs rejected a text.
enum class SecondsParseError { kSyntax, kOverflow };

/// Result of ParseSecondsToNs: either t_ns or an error.
struct SecondsParseResult {
  std::optional<int64_t> t_ns;
  SecondsParseError error = SecondsParseError::kSyntax;  ///< meaningful only when !t_ns
};

/// Parses `[+-]digits[.digits][(e|E)[+-]digits]` (at least one mantissa digit, nothing else) as seconds
/// into nanoseconds, exactly. Digits below 1 ns are rounded to the nearest ns, halves away from zero.
/// kOverflow when the value does not fit int64 ns (|t| > ~292 years).
SecondsParseResult ParseSecondsToNs(std::string_view text);

/// Writes t_ns as seconds with exactly nine decimals ("-0.000000001", "1403715529.112143517");
/// ParseSecondsToNs(FormatNsAsSeconds(t)) == t for every int64 t.
std::string FormatNsAsSeconds(int64_t t_ns);

}  // namespace rs
