#include "formats/frame_priors.h"

#include <fmt/format.h>

#include <array>
#include <cmath>
#include <fstream>
#include <sstream>

#include "formats/checked_file.h"
#include "formats/input_error.h"

namespace rs {
namespace {

constexpr const char* kHeader =
    "frame_id,t_ns,t_log_ns,status,lat_deg,lon_deg,alt_m,alt_ref,h_acc_m,has_attitude,qw,qx,qy,qz";

std::string Num(double v) { return std::isnan(v) ? std::string() : fmt::format("{:.10g}", v); }

double ParseDouble(const std::string& s, const InputLocation& where) {
  if (s.empty()) return kNaN;
  size_t used = 0;
  try {
    const double v = std::stod(s, &used);
    if (used == s.size()) return v;
  } catch (const std::exception&) {}
  throw InputError(where, fmt::format("'{}' is not a number", s));
}

int64_t ParseInt(const std::string& s, const InputLocation& where) {
  size_t used = 0;
  try {
    const int64_t v = std::stoll(s, &used);
    if (used == s.size()) return v;
  } catch (const std::exception&) {}
  throw InputError(where, fmt::format("'{}' is not an integer", s));
}

template <class E, size_t N>
E ParseEnum(const std::string& s, const std::array<E, N>& values, const InputLocation& where) {
  for (E v : values)
    if (s == ToString(v)) return v;
  throw InputError(where, fmt::format("unknown value '{}'", s));
}

}  // namespace

const char* ToString(PriorStatus s) {
  switch (s) {
    case PriorStatus::kOk: return "ok";
    case PriorStatus::kOutsideSpan: return "outside-span";
    case PriorStatus::kInGap: return "in-gap";
    case PriorStatus::kNoLog: return "no-log";
  }
  return "?";
}

void WriteFramePriors(std::ostream& out, const std::vector<FramePrior>& priors) {
  out << kHeader << '\n';
  for (const auto& p : priors) {
    out << fmt::format("{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n", p.id.value, p.t_ns, p.t_log_ns,
                       ToString(p.status), p.status == PriorStatus::kOk ? fmt::format("{:.10f}", p.lat_deg) : "",
                       p.status == PriorStatus::kOk ? fmt::format("{:.10f}", p.lon_deg) : "", Num(p.alt_m),
                       ToString(p.alt_ref), Num(p.h_acc_m), p.has_attitude ? 1 : 0, Num(p.qw), Num(p.qx), Num(p.qy),
                       Num(p.qz));
  }
}

void WriteFramePriors(const std::filesystem::path& path, const std::vector<FramePrior>& priors) {
  WriteStreamChecked(path, [&](std::ostream& out) { WriteFramePriors(out, priors); });
}

std::vector<FramePrior> ReadFramePriors(std::istream& in, const std::string& path) {
  std::string line;
  if (!std::getline(in, line) || line != kHeader)
    throw InputError(InputLocation::Line(path, 1), fmt::format("expected header '{}'", kHeader));
  std::vector<FramePrior> priors;
  int64_t line_no = 1;
  const std::array<PriorStatus, 4> statuses = {PriorStatus::kOk, PriorStatus::kOutsideSpan, PriorStatus::kInGap,
                                               PriorStatus::kNoLog};
  const std::array<AltitudeReference, 4> refs = {AltitudeReference::kUnknown, AltitudeReference::kEllipsoid,
                                                 AltitudeReference::kAmsl, AltitudeReference::kTakeoff};
  while (std::getline(in, line)) {
    ++line_no;
    if (line.empty()) continue;
    const auto where = InputLocation::Line(path, line_no);
    std::vector<std::string> f;
    std::stringstream ss(line);
    std::string field;
    while (std::getline(ss, field, ',')) f.push_back(field);
    if (!line.empty() && line.back() == ',') f.emplace_back();
    if (f.size() != 14) throw InputError(where, fmt::format("expected 14 fields, got {}", f.size()));
    FramePrior p;
    p.id.value = ParseInt(f[0], where);
    p.t_ns = ParseInt(f[1], where);
    p.t_log_ns = ParseInt(f[2], where);
    p.status = ParseEnum(f[3], statuses, where);
    p.lat_deg = ParseDouble(f[4], where);
    p.lon_deg = ParseDouble(f[5], where);
    p.alt_m = ParseDouble(f[6], where);
    p.alt_ref = ParseEnum(f[7], refs, where);
    p.h_acc_m = ParseDouble(f[8], where);
    p.has_attitude = f[9] == "1";
    p.qw = ParseDouble(f[10], where);
    p.qx = ParseDouble(f[11], where);
    p.qy = ParseDouble(f[12], where);
    p.qz = ParseDouble(f[13], where);
    priors.push_back(p);
  }
  return priors;
}

std::vector<FramePrior> ReadFramePriors(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw InputError(InputLocation::File(path.string()), "cannot open frame priors");
  return ReadFramePriors(in, path.string());
}

}  // namespace rs
