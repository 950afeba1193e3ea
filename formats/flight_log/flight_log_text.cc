#include "formats/flight_log/flight_log_text.h"

#include <charconv>
#include <cmath>

namespace rs::flightlog {

bool SplitCsvLine(std::string_view line, std::vector<CsvField>* fields, int64_t* error_column, char delim) {
  fields->clear();
  size_t i = 0;
  const size_t n = line.size();
  while (true) {
    CsvField f;
    f.column = static_cast<int64_t>(i) + 1;
    // Leading blanks before a quote are tolerated (", \"x\"").
    size_t j = i;
    while (j < n && (line[j] == ' ' || line[j] == '\t')) ++j;
    if (j < n && line[j] == '"') {
      const size_t quote_pos = j;
      ++j;
      bool closed = false;
      while (j < n) {
        if (line[j] == '"') {
          if (j + 1 < n && line[j + 1] == '"') {
            f.text += '"';
            j += 2;
            continue;
          }
          closed = true;
          ++j;
          break;
        }
        f.text += line[j++];
      }
      if (!closed) {
        *error_column = static_cast<int64_t>(quote_pos) + 1;
        return false;
      }
      while (j < n && line[j] != delim) ++j;  // anything after the closing quote is ignored blanks
      i = j;
    } else {
      while (i < n && line[i] != delim) f.text += line[i++];
    }
    fields->push_back(std::move(f));
    if (i >= n) break;
    ++i;           // skip the comma
    if (i == n) {  // trailing comma: one more empty field
      fields->push_back({std::string(), static_cast<int64_t>(i) + 1});
      break;
    }
  }
  return true;
}

std::string_view Trim(std::string_view s) {
  size_t b = 0, e = s.size();
  while (b < e && (s[b] == ' ' || s[b] == '\t' || s[b] == '\r' || s[b] == '\n')) ++b;
  while (e > b && (s[e - 1] == ' ' || s[e - 1] == '\t' || s[e - 1] == '\r' || s[e - 1] == '\n')) --e;
  return s.substr(b, e - b);
}

bool ParseDouble(std::string_view s, double* out) {
  s = Trim(s);
  if (s.empty()) return false;
  if (s.front() == '+') s.remove_prefix(1);
  double v = 0;
  auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v, std::chars_format::general);
  if (ec != std::errc() || p != s.data() + s.size() || !std::isfinite(v)) return false;
  *out = v;
  return true;
}

bool ParseInt64(std::string_view s, int64_t* out) {
  s = Trim(s);
  if (s.empty()) return false;
  if (s.front() == '+') s.remove_prefix(1);
  int64_t v = 0;
  auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || p != s.data() + s.size()) return false;
  *out = v;
  return true;
}

std::string ToLowerAscii(std::string_view s) {
  std::string r(s);
  for (char& c : r)
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  return r;
}

bool GetLineBounded(std::istream& in, std::string* line, size_t max_len, bool* too_long) {
  line->clear();
  *too_long = false;
  std::streambuf* sb = in.rdbuf();
  if (!in.good() || sb == nullptr) return false;
  bool any = false;
  while (true) {
    const int c = sb->sbumpc();
    if (c == std::char_traits<char>::eof()) {
      in.setstate(std::ios::eofbit);
      break;
    }
    any = true;
    if (c == '\n') break;
    if (line->size() >= max_len) {
      *too_long = true;
      return false;
    }
    line->push_back(static_cast<char>(c));
  }
  if (!line->empty() && line->back() == '\r') line->pop_back();
  return any;
}

std::string FormatDouble(double v) {
  char buf[64];
  auto [p, ec] = std::to_chars(buf, buf + sizeof(buf), v);
  return std::string(buf, ec == std::errc() ? p : buf);
}

}  // namespace rs::flightlog
