#include "formats/frame_index.h"

#include <fmt/format.h>

#include <charconv>
#include <fstream>
#include <sstream>

#include "formats/checked_file.h"
#include "formats/input_error.h"

namespace rs {
namespace {

constexpr const char* kHeader = "frame_id,t_ns,left,right";

// Paths are written quoted (RFC 4180) so commas in folder names survive.
std::string Quote(const std::string& s) {
  std::string out = "\"";
  for (char c : s) out += (c == '"') ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

std::vector<std::string> SplitCsvLine(const std::string& line, const InputLocation& where) {
  std::vector<std::string> fields(1);
  bool quoted = false;
  for (size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        fields.back() += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        fields.back() += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      fields.emplace_back();
    } else {
      fields.back() += c;
    }
  }
  if (quoted) throw InputError(where, "unterminated quoted field");
  return fields;
}

int64_t ParseInt(const std::string& s, const InputLocation& where, const char* what) {
  int64_t v = 0;
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || ptr != s.data() + s.size())
    throw InputError(where, fmt::format("{} '{}' is not an integer", what, s));
  return v;
}

}  // namespace

void WriteFrameIndex(std::ostream& out, const std::vector<FrameRecord>& frames) {
  out << kHeader << '\n';
  for (const auto& f : frames)
    out << f.id.value << ',' << f.t_ns << ',' << Quote(f.left.string()) << ',' << Quote(f.right.string()) << '\n';
}

void WriteFrameIndex(const std::filesystem::path& path, const std::vector<FrameRecord>& frames) {
  WriteStreamChecked(path, [&](std::ostream& out) { WriteFrameIndex(out, frames); });
}

std::vector<FrameRecord> ReadFrameIndex(std::istream& in, const std::string& path) {
  std::vector<FrameRecord> frames;
  std::string line;
  int64_t line_no = 0;
  if (!std::getline(in, line) || line != kHeader)
    throw InputError(InputLocation::Line(path, 1), fmt::format("expected header '{}'", kHeader));
  ++line_no;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.empty()) continue;
    const auto where = InputLocation::Line(path, line_no);
    const auto fields = SplitCsvLine(line, where);
    if (fields.size() != 4) throw InputError(where, fmt::format("expected 4 fields, got {}", fields.size()));
    FrameRecord f;
    f.id.value = ParseInt(fields[0], where, "frame_id");
    f.t_ns = ParseInt(fields[1], where, "t_ns");
    f.left = fields[2];
    f.right = fields[3];
    frames.push_back(std::move(f));
  }
  return frames;
}

std::vector<FrameRecord> ReadFrameIndex(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw InputError(InputLocation::File(path.string()), "cannot open frame index");
  return ReadFrameIndex(in, path.string());
}

}  // namespace rs
