#pragma once
// Small text-parsing helpers shared by the flight-log text readers: strict
// number parsing (no locale, no silent partial parses) and CSV field splitting
// that remembers each field's column so errors can point at it.
// Kept apart from formats/trajectory/trajectory_text.h on purpose: these report
// failure by return value and split quoted CSV; that one throws and splits plain CSV.

#include <cstdint>
#include <istream>
#include <string>
#include <string_view>
#include <vector>

namespace rs::flightlog {

/// One CSV field and the 1-based column of its first character in the line.
struct CsvField {
  std::string text;
  int64_t column = 1;
};

/// Splits one CSV line at `delim`. Fields may be double-quoted ("a,b", "" = ").
/// Returns false (and sets *error_column) on an unterminated quote.
bool SplitCsvLine(std::string_view line, std::vector<CsvField>* fields, int64_t* error_column, char delim = ',');

/// Strips leading/trailing ASCII whitespace.
std::string_view Trim(std::string_view s);

/// Parses the whole of `s` (after trimming) as a finite double; false on
/// anything else (empty, trailing junk, nan, inf, out of range).
bool ParseDouble(std::string_view s, double* out);

/// Parses the whole of `s` (after trimming) as a base-10 int64.
bool ParseInt64(std::string_view s, int64_t* out);

/// Lower-cases ASCII letters.
std::string ToLowerAscii(std::string_view s);

/// Reads one line, dropping a trailing '\r'. Refuses lines longer than
/// `max_len` bytes (returns false with *too_long set) so a binary file fed to a
/// text reader cannot make us buffer it whole as one line.
bool GetLineBounded(std::istream& in, std::string* line, size_t max_len, bool* too_long);

/// Formats a double with the shortest text that parses back to the same value.
std::string FormatDouble(double v);

}  // namespace rs::flightlog
