#include "formats/flight_log/time_parse.h"

#include <cstdio>

#include "formats/flight_log/flight_log_text.h"

namespace rs::flightlog {
namespace {

bool IsDigit(char c) { return c >= '0' && c <= '9'; }

// Reads exactly `n` digits at s[*i].
bool Digits(std::string_view s, size_t* i, int n, int64_t* v) {
  *v = 0;
  for (int k = 0; k < n; ++k) {
    if (*i >= s.size() || !IsDigit(s[*i])) return false;
    *v = *v * 10 + (s[(*i)++] - '0');
  }
  return true;
}

// Reads 1..max_n digits at s[*i].
bool DigitsUpTo(std::string_view s, size_t* i, int max_n, int64_t* v) {
  *v = 0;
  int k = 0;
  while (k < max_n && *i < s.size() && IsDigit(s[*i])) {
    *v = *v * 10 + (s[(*i)++] - '0');
    ++k;
  }
  return k > 0;
}

// Reads a run of digits as a fraction of a second: keeps 9 digits, truncates the rest.
bool Fraction(std::string_view s, size_t* i, int64_t* frac_ns) {
  int64_t v = 0;
  int k = 0;
  while (*i < s.size() && IsDigit(s[*i])) {
    if (k < 9) v = v * 10 + (s[*i] - '0');
    ++k;
    ++*i;
  }
  if (k == 0) return false;
  for (int j = k; j < 9; ++j) v *= 10;
  *frac_ns = v;
  return true;
}

bool IsLeap(int64_t y) { return (y % 4 == 0 && y % 100 != 0) || y % 400 == 0; }

}  // namespace

int64_t DaysFromCivil(int64_t y, int64_t m, int64_t d) {
  // Howard Hinnant's days_from_civil.
  y -= m <= 2;
  const int64_t era = (y >= 0 ? y : y - 399) / 400;
  const int64_t yoe = y - era * 400;
  const int64_t doy = (153 * (m + (m > 2 ? -3 : 9)) + 2) / 5 + d - 1;
  const int64_t doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  return era * 146097 + doe - 719468;
}

bool CivilToNs(int64_t y, int64_t mo, int64_t d, int64_t h, int64_t mi, int64_t s, int64_t frac_ns, int64_t* t_ns) {
  static constexpr int kDays[] = {31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};
  if (y < 1900 || y > 2200 || mo < 1 || mo > 12 || d < 1) return false;
  const int dim = kDays[mo - 1] + (mo == 2 && IsLeap(y) ? 1 : 0);
  if (d > dim || h > 23 || mi > 59 || s > 60 || frac_ns < 0 || frac_ns >= 1000000000) return false;
  const int64_t secs = DaysFromCivil(y, mo, d) * 86400 + h * 3600 + mi * 60 + s;
  *t_ns = secs * 1000000000 + frac_ns;
  return true;
}

bool ParseIso8601(std::string_view s, int64_t* t_ns, bool* has_zone) {
  s = Trim(s);
  size_t i = 0;
  int64_t y, mo, d, h, mi, sec = 0, frac = 0;
  if (!Digits(s, &i, 4, &y) || i >= s.size() || s[i++] != '-') return false;
  if (!Digits(s, &i, 2, &mo) || i >= s.size() || s[i++] != '-') return false;
  if (!Digits(s, &i, 2, &d) || i >= s.size() || (s[i] != 'T' && s[i] != 't' && s[i] != ' ')) return false;
  ++i;
  if (!Digits(s, &i, 2, &h) || i >= s.size() || s[i++] != ':') return false;
  if (!Digits(s, &i, 2, &mi)) return false;
  if (i < s.size() && s[i] == ':') {
    ++i;
    if (!Digits(s, &i, 2, &sec)) return false;
    if (i < s.size() && (s[i] == '.' || s[i] == ',')) {
      ++i;
      if (!Fraction(s, &i, &frac)) return false;
    }
  }
  int64_t offset_s = 0;
  *has_zone = false;
  if (i < s.size()) {
    if (s[i] == 'Z' || s[i] == 'z') {
      ++i;
      *has_zone = true;
    } else if (s[i] == '+' || s[i] == '-') {
      const int64_t sign = s[i++] == '-' ? -1 : 1;
      int64_t oh, om = 0;
      if (!Digits(s, &i, 2, &oh)) return false;
      if (i < s.size() && s[i] == ':') ++i;
      if (i < s.size() && !Digits(s, &i, 2, &om)) return false;
      if (oh > 23 || om > 59) return false;
      offset_s = sign * (oh * 3600 + om * 60);
      *has_zone = true;
    }
  }
  if (i != s.size()) return false;
  int64_t local_ns;
  if (!CivilToNs(y, mo, d, h, mi, sec, frac, &local_ns)) return false;
  *t_ns = local_ns - offset_s * 1000000000;
  return true;
}

bool ParseDjiDateTime(std::string_view s, size_t* consumed, int64_t* t_ns) {
  size_t i = 0;
  int64_t y, mo, d, h, mi, sec, frac = 0;
  if (!Digits(s, &i, 4, &y) || i >= s.size() || (s[i] != '-' && s[i] != '.')) return false;
  const char sep = s[i++];
  if (!DigitsUpTo(s, &i, 2, &mo) || i >= s.size() || s[i++] != sep) return false;
  if (!DigitsUpTo(s, &i, 2, &d) || i >= s.size() || s[i++] != ' ') return false;
  if (!DigitsUpTo(s, &i, 2, &h) || i >= s.size() || s[i++] != ':') return false;
  if (!Digits(s, &i, 2, &mi) || i >= s.size() || s[i++] != ':') return false;
  if (!Digits(s, &i, 2, &sec)) return false;
  if (i + 1 < s.size() && s[i] == '.' && IsDigit(s[i + 1])) {
    ++i;
    if (!Fraction(s, &i, &frac)) return false;
  } else if (i + 3 < s.size() && s[i] == ',' && IsDigit(s[i + 1])) {
    // DJI writes ",mmm,uuu" (milliseconds, microseconds); some firmware repeats groups.
    size_t j = i + 1;
    int64_t ms;
    if (Digits(s, &j, 3, &ms)) {
      frac = ms * 1000000;
      i = j;
      int64_t us;
      size_t k = i + 1;
      if (i < s.size() && s[i] == ',' && Digits(s, &k, 3, &us)) {
        frac += us * 1000;
        i = k;
      }
    }
  }
  if (!CivilToNs(y, mo, d, h, mi, sec, frac, t_ns)) return false;
  *consumed = i;
  return true;
}

std::string FormatIsoNs(int64_t t_ns) {
  // Howard Hinnant's civil_from_days.
  int64_t secs = t_ns / 1000000000, frac = t_ns % 1000000000;
  if (frac < 0) frac += 1000000000, --secs;
  int64_t days = secs / 86400, sod = secs % 86400;
  if (sod < 0) sod += 86400, --days;
  const int64_t z = days + 719468;
  const int64_t era = (z >= 0 ? z : z - 146096) / 146097;
  const int64_t doe = z - era * 146097;
  const int64_t yoe = (doe - doe / 1460 + doe / 36524 - doe / 146096) / 365;
  const int64_t doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
  const int64_t mp = (5 * doy + 2) / 153;
  const int64_t d = doy - (153 * mp + 2) / 5 + 1;
  const int64_t m = mp < 10 ? mp + 3 : mp - 9;
  const int64_t y = yoe + era * 400 + (m <= 2);
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%04lld-%02lld-%02lldT%02lld:%02lld:%02lld.%09lld", static_cast<long long>(y),
                static_cast<long long>(m), static_cast<long long>(d), static_cast<long long>(sod / 3600),
                static_cast<long long>(sod / 60 % 60), static_cast<long long>(sod % 60), static_cast<long long>(frac));
  return buf;
}

}  // namespace rs::flightlog
