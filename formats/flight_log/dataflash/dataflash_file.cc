#include "formats/flight_log/dataflash/dataflash_file.h"

#include <array>
#include <cmath>
#include <cstring>
#include <fstream>

#include <fmt/format.h>

#include "formats/input_error.h"

namespace rs::dataflash {
namespace {

constexpr uint8_t kHead1 = 0xA3, kHead2 = 0x95;
constexpr uint8_t kFmtType = 128;
constexpr size_t kFmtLength = 89;  // 3 header + B B n N Z

template <typename T>
T Load(const uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));  // DataFlash is little-endian, as is every host we build for
  return v;
}

std::string FixedText(const uint8_t* p, size_t n) {
  size_t len = 0;
  while (len < n && p[len] != 0) ++len;
  return std::string(reinterpret_cast<const char*>(p), len);
}

std::vector<uint8_t> ReadAll(std::istream& in) {
  // Grows with what the stream delivers; never sized from a field in the file.
  std::vector<uint8_t> data;
  std::vector<char> chunk(1 << 16);
  while (in) {
    in.read(chunk.data(), static_cast<std::streamsize>(chunk.size()));
    const std::streamsize n = in.gcount();
    if (n <= 0) break;
    data.insert(data.end(), chunk.begin(), chunk.begin() + n);
  }
  return data;
}

class Parser {
 public:
  Parser(const std::vector<uint8_t>& d, DataflashFile* f) : d_(d), f_(*f) { by_type_.fill(-1); }

  void Run() {
    size_t pos = 0;
    while (pos + 3 <= d_.size()) {
      if (d_[pos] != kHead1 || d_[pos + 1] != kHead2) {
        Skipping(pos, "no message header (0xA3 0x95)");
        ++pos;
        continue;
      }
      const uint8_t t = d_[pos + 2];
      if (t == kFmtType) {
        if (pos + kFmtLength > d_.size()) break;  // truncated tail, counted below
        EndSkip(pos);
        Fmt(&d_[pos + 3]);
        pos += kFmtLength;
        continue;
      }
      if (by_type_[t] < 0) {
        Skipping(pos, fmt::format("message type {} without a usable FMT", t));
        ++pos;
        continue;
      }
      MessageType& m = f_.types[static_cast<size_t>(by_type_[t])];
      if (pos + m.length > d_.size()) break;
      EndSkip(pos);
      m.payloads.insert(m.payloads.end(), d_.begin() + static_cast<std::ptrdiff_t>(pos + 3),
                        d_.begin() + static_cast<std::ptrdiff_t>(pos + m.length));
      m.offsets.push_back(static_cast<int64_t>(pos));
      ++decoded_;
      pos += m.length;
    }
    if (pos < d_.size()) {
      EndSkip(pos);
      Skipping(pos, "truncated message at end of file");
      pos = d_.size();
    }
    EndSkip(pos);
  }

  int64_t decoded() const { return decoded_; }
  int fmt_count() const { return fmt_count_; }

 private:
  void Skipping(size_t pos, std::string reason) {
    if (skip_start_ < 0) {
      skip_start_ = static_cast<int64_t>(pos);
      skip_reason_ = std::move(reason);
    }
  }
  void EndSkip(size_t pos) {
    if (skip_start_ < 0) return;
    const int64_t n = static_cast<int64_t>(pos) - skip_start_;
    f_.skipped_bytes += n;
    ++f_.skip_runs;
    if (f_.skips.size() < DataflashFile::kMaxRecordedSkips) f_.skips.push_back({skip_start_, n, skip_reason_});
    skip_start_ = -1;
  }

  void Fmt(const uint8_t* p) {
    ++fmt_count_;
    const uint8_t type = p[0], length = p[1];
    MessageType m;
    m.type = type;
    m.length = length;
    m.name = FixedText(p + 2, 4);
    m.format = FixedText(p + 6, 16);
    const std::string cols = FixedText(p + 22, 64);
    if (type == kFmtType) return;  // FMT describing itself: the layout is fixed
    bool ok = !m.name.empty();
    for (char c : m.name) ok = ok && c > 32 && c < 127;
    std::vector<std::string> names;
    for (size_t start = 0; start <= cols.size() && !cols.empty();) {
      size_t comma = cols.find(',', start);
      if (comma == std::string::npos) comma = cols.size();
      names.push_back(cols.substr(start, comma - start));
      start = comma + 1;
    }
    uint32_t offset = 0;
    for (size_t i = 0; i < m.format.size() && ok; ++i) {
      const int size = FormatCharSize(m.format[i]);
      if (size == 0) {
        ok = false;
        break;
      }
      Column c;
      c.name = i < names.size() ? names[i] : fmt::format("_col{}", i);
      c.type = m.format[i];
      c.offset = offset;
      offset += static_cast<uint32_t>(size);
      m.columns.push_back(std::move(c));
    }
    if (!ok || length < 3 || offset > length - 3u) {
      ++f_.rejected_formats;  // records of this type will be skipped and counted
      by_type_[type] = -1;
      return;
    }
    // A log restart re-sends identical FMTs: keep appending to the same type.
    auto it = f_.by_name.find(m.name);
    if (it != f_.by_name.end()) {
      const MessageType& old = f_.types[it->second];
      if (old.type == m.type && old.length == m.length && old.format == m.format) {
        by_type_[type] = static_cast<int>(it->second);
        return;
      }
    }
    f_.types.push_back(std::move(m));
    f_.by_name[f_.types.back().name] = f_.types.size() - 1;
    by_type_[type] = static_cast<int>(f_.types.size() - 1);
  }

  const std::vector<uint8_t>& d_;
  DataflashFile& f_;
  std::array<int, 256> by_type_;
  int64_t skip_start_ = -1;
  std::string skip_reason_;
  int64_t decoded_ = 0;
  int fmt_count_ = 0;
};

// Attaches FMTU units and multipliers to the columns they describe.
void ApplyFmtu(DataflashFile* f) {
  const MessageType* fmtu = f->Find("FMTU");
  if (!fmtu) return;
  std::map<char, std::string> units;
  std::map<char, double> mults;
  if (const MessageType* u = f->Find("UNIT")) {
    const auto id = u->ColumnIndex("Id"), label = u->ColumnIndex("Label");
    if (id && label) {
      for (size_t r = 0; r < u->size(); ++r) units[static_cast<char>(u->Int(r, *id))] = u->Text(r, *label);
    }
  }
  if (const MessageType* m = f->Find("MULT")) {
    const auto id = m->ColumnIndex("Id"), mult = m->ColumnIndex("Mult");
    if (id && mult) {
      for (size_t r = 0; r < m->size(); ++r) mults[static_cast<char>(m->Int(r, *id))] = m->Value(r, *mult);
    }
  }
  const auto ftype = fmtu->ColumnIndex("FmtType"), uids = fmtu->ColumnIndex("UnitIds"),
             mids = fmtu->ColumnIndex("MultIds");
  if (!ftype || !uids || !mids) return;
  for (size_t r = 0; r < fmtu->size(); ++r) {
    const int type = static_cast<int>(fmtu->Int(r, *ftype));
    const std::string u = fmtu->Text(r, *uids), mu = fmtu->Text(r, *mids);
    for (MessageType& t : f->types) {
      if (t.type != type) continue;
      for (size_t i = 0; i < t.columns.size(); ++i) {
        if (i < u.size() && units.count(u[i])) t.columns[i].unit = units[u[i]];
        if (i < mu.size() && mults.count(mu[i])) t.columns[i].fmtu_multiplier = mults[mu[i]];
      }
    }
  }
}

}  // namespace

int FormatCharSize(char c) {
  switch (c) {
    case 'b':
    case 'B':
    case 'M': return 1;
    case 'h':
    case 'H':
    case 'c':
    case 'C': return 2;
    case 'i':
    case 'I':
    case 'f':
    case 'e':
    case 'E':
    case 'L':
    case 'n': return 4;
    case 'd':
    case 'q':
    case 'Q': return 8;
    case 'N': return 16;
    case 'Z':
    case 'a': return 64;
    default: return 0;
  }
}

double FormatCharScale(char c) {
  switch (c) {
    case 'c':
    case 'C':
    case 'e':
    case 'E': return 0.01;
    case 'L': return 1e-7;
    default: return 1.0;
  }
}

std::optional<size_t> MessageType::ColumnIndex(const std::string& column) const {
  for (size_t i = 0; i < columns.size(); ++i) {
    if (columns[i].name == column) return i;
  }
  return std::nullopt;
}

int64_t MessageType::Int(size_t row, size_t column) const {
  const Column& c = columns[column];
  const uint8_t* p = payloads.data() + row * payload_size() + c.offset;
  switch (c.type) {
    case 'b': return Load<int8_t>(p);
    case 'B':
    case 'M': return Load<uint8_t>(p);
    case 'h':
    case 'c': return Load<int16_t>(p);
    case 'H':
    case 'C': return Load<uint16_t>(p);
    case 'i':
    case 'e':
    case 'L': return Load<int32_t>(p);
    case 'I':
    case 'E': return Load<uint32_t>(p);
    case 'q': return Load<int64_t>(p);
    case 'Q': return static_cast<int64_t>(Load<uint64_t>(p));
    default: return 0;
  }
}

double MessageType::Value(size_t row, size_t column) const {
  const Column& c = columns[column];
  const uint8_t* p = payloads.data() + row * payload_size() + c.offset;
  switch (c.type) {
    case 'f': return Load<float>(p);
    case 'd': return Load<double>(p);
    case 'Q': return static_cast<double>(Load<uint64_t>(p));
    case 'n':
    case 'N':
    case 'Z':
    case 'a': return std::nan("");
    default: return static_cast<double>(Int(row, column)) * FormatCharScale(c.type);
  }
}

std::string MessageType::Text(size_t row, size_t column) const {
  const Column& c = columns[column];
  const uint8_t* p = payloads.data() + row * payload_size() + c.offset;
  if (c.type != 'n' && c.type != 'N' && c.type != 'Z') return {};
  return FixedText(p, static_cast<size_t>(FormatCharSize(c.type)));
}

const MessageType* DataflashFile::Find(const std::string& name) const {
  auto it = by_name.find(name);
  if (it == by_name.end() || types[it->second].size() == 0) return nullptr;
  return &types[it->second];
}

DataflashFile ReadDataflashFile(std::istream& in, const std::string& path) {
  const std::vector<uint8_t> data = ReadAll(in);
  if (in.bad()) throw InputError(InputLocation::File(path), "read error");
  DataflashFile f;
  Parser p(data, &f);
  p.Run();
  if (p.fmt_count() == 0) {
    throw InputError(InputLocation::Byte(path, 0),
                     fmt::format("not a DataFlash log: no FMT message in {} bytes", data.size()));
  }
  ApplyFmtu(&f);
  return f;
}

DataflashFile ReadDataflashFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(InputLocation::File(path.string()), "cannot open file");
  return ReadDataflashFile(in, path.string());
}

}  // namespace rs::dataflash
