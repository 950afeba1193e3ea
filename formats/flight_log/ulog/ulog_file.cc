#include "formats/flight_log/ulog/ulog_file.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <stdexcept>

#include <fmt/format.h>

#include "formats/input_error.h"

namespace rs::ulog {
namespace {

constexpr uint8_t kMagic[7] = {0x55, 0x4c, 0x6f, 0x67, 0x01, 0x12, 0x35};
constexpr uint8_t kSyncMagic[8] = {0x2F, 0x73, 0x13, 0x20, 0x25, 0x0C, 0xBB, 0x12};
constexpr size_t kHeaderSize = 16;
constexpr size_t kMsgHeaderSize = 3;
// A data message carries at most 65535 - 2 bytes of record, so no record type
// can be larger; this also bounds what a hostile nested definition can expand to.
constexpr uint32_t kMaxRecordBytes = 65535;
constexpr int kMaxNestingDepth = 32;

uint16_t U16(const uint8_t* p) { return static_cast<uint16_t>(p[0] | (p[1] << 8)); }
uint64_t U64(const uint8_t* p) {
  uint64_t v = 0;
  for (int i = 7; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}
template <typename T>
T Load(const uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));  // ULog is little-endian, as is every host we build for
  return v;
}

std::vector<uint8_t> ReadAll(std::istream& in) {
  // Grows with what the stream actually delivers; never sized from a field in the file.
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

std::string PythonFloat(double v) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  std::string s = fmt::format("{}", v);
  if (s.find_first_of(".en") == std::string::npos) s += ".0";
  return s;
}

// Parses "type", "type[n]" and "type name" pieces of a format definition.
bool ParseFormatField(const std::string& text, FormatField* out) {
  const size_t space = text.find(' ');
  if (space == std::string::npos || space == 0 || space + 1 >= text.size()) return false;
  std::string type = text.substr(0, space);
  out->name = text.substr(space + 1);
  out->array_size = 0;
  const size_t lb = type.find('[');
  if (lb != std::string::npos) {
    const size_t rb = type.find(']', lb);
    if (rb == std::string::npos || rb != type.size() - 1 || rb == lb + 1 || rb - lb > 6) return false;
    int n = 0;
    for (size_t i = lb + 1; i < rb; ++i) {
      if (type[i] < '0' || type[i] > '9') return false;
      n = n * 10 + (type[i] - '0');
    }
    if (n < 1 || n > 65535) return false;
    out->array_size = n;
    type = type.substr(0, lb);
  }
  if (type.empty()) return false;
  out->type_name = type;
  return true;
}

struct Flattener {
  const std::map<std::string, MessageFormat>& formats;
  std::vector<FlatField> out;
  uint32_t offset = 0;

  void Add(const std::string& name, BaseType t) {
    const uint32_t size = static_cast<uint32_t>(BaseTypeSize(t));
    if (offset + size > kMaxRecordBytes) throw std::invalid_argument("record larger than 64 KiB");
    out.push_back({name, t, offset});
    offset += size;
  }
  void Flatten(const std::string& prefix, const std::string& type_name, int depth) {
    if (depth > kMaxNestingDepth)
      throw std::invalid_argument("format nesting too deep (recursive type '" + type_name + "'?)");
    auto it = formats.find(type_name);
    if (it == formats.end()) throw std::invalid_argument("undefined format '" + type_name + "'");
    for (const FormatField& f : it->second.fields) {
      BaseType bt;
      const bool base = ParseBaseType(f.type_name, &bt);
      // pyulog names "type[1] x" like a scalar; we follow it so field names match.
      if (f.array_size > 1) {
        for (int i = 0; i < f.array_size; ++i) {
          const std::string n = prefix + f.name + "[" + std::to_string(i) + "]";
          if (base) {
            Add(n, bt);
          } else {
            Flatten(n + ".", f.type_name, depth + 1);
          }
          if (out.size() > kMaxRecordBytes) throw std::invalid_argument("too many fields");
        }
      } else if (base) {
        Add(prefix + f.name, bt);
      } else {
        Flatten(prefix + f.name + ".", f.type_name, depth + 1);
      }
      if (out.size() > kMaxRecordBytes) throw std::invalid_argument("too many fields");
    }
  }
};

class Parser {
 public:
  Parser(const std::vector<uint8_t>& d, const std::string& path, const ReadOptions& opt, UlogFile* f)
      : d_(d), path_(path), opt_(opt), f_(*f) {}

  void Run() {
    if (d_.size() < kHeaderSize) Fail(0, fmt::format("not a ULog file: {} bytes, header needs 16", d_.size()));
    if (std::memcmp(d_.data(), kMagic, sizeof(kMagic)) != 0) Fail(0, "not a ULog file: bad magic bytes");
    f_.version = d_[7];
    f_.start_timestamp_us = U64(&d_[8]);
    f_.last_timestamp_us = f_.start_timestamp_us;

    size_t pos = kHeaderSize;
    size_t next_offset = 0;  // index into appended_offsets once known
    while (true) {
      // End of the current segment: the next appended-data offset, or the file end.
      size_t seg_end = d_.size();
      const bool at_offset = next_offset < f_.appended_offsets.size();
      if (at_offset) seg_end = static_cast<size_t>(f_.appended_offsets[next_offset]);
      if (pos >= seg_end) {
        if (!at_offset) break;
        pos = std::max(pos, seg_end);
        ++next_offset;
        continue;
      }
      if (seg_end - pos < kMsgHeaderSize || seg_end - pos - kMsgHeaderSize < U16(&d_[pos])) {
        if (at_offset) {
          // Appended data (crash dumps) starts at a fixed offset; the message
          // being written there when the logger stopped is cut, as the spec allows.
          ++f_.messages_cut_at_appended_offset;
          pos = seg_end;
          ++next_offset;
          continue;
        }
        const size_t need = seg_end - pos < kMsgHeaderSize ? kMsgHeaderSize : kMsgHeaderSize + U16(&d_[pos]);
        const std::string reason = fmt::format("truncated message: needs {} bytes, {} remain", need, seg_end - pos);
        if (opt_.read_to_cut) {
          f_.cut = CutShort{static_cast<int64_t>(pos), static_cast<int64_t>(d_.size()), messages_read_, reason};
        } else {
          Truncated(pos, reason);
        }
        break;
      }
      pos = Message(pos);
      ++messages_read_;
    }
    Finish();
  }

 private:
  [[noreturn]] void Fail(size_t at, const std::string& msg) {
    throw InputError(InputLocation::Byte(path_, static_cast<int64_t>(at)), msg);
  }

  void Truncated(size_t at, const std::string& msg) {
    if (!opt_.recover) Fail(at, msg);
    f_.skips.push_back({static_cast<int64_t>(at), static_cast<int64_t>(d_.size() - at), msg});
  }

  // Handles corruption found in the message at `at` (whose header claims it
  // ends at `msg_end`). Returns where to continue.
  size_t Corrupt(size_t at, size_t msg_end, const std::string& msg) {
    if (!opt_.recover) Fail(at, msg);
    size_t resume = d_.size();
    if (msg_end <= d_.size() && (msg_end == d_.size() || PlausibleChain(msg_end))) {
      resume = msg_end;  // only this message is bad; its header still frames it correctly
    } else {
      for (size_t q = at + 1; q + kMsgHeaderSize <= d_.size(); ++q) {
        if (d_[q] == kSyncMagic[0] && q + 8 <= d_.size() && std::memcmp(&d_[q], kSyncMagic, 8) == 0) {
          resume = q + 8;
          break;
        }
        if (PlausibleChain(q)) {
          resume = q;
          break;
        }
      }
    }
    f_.skips.push_back({static_cast<int64_t>(at), static_cast<int64_t>(resume - at), msg});
    return resume;
  }

  // Does a well-formed message that fits the file start at q?
  bool Plausible(size_t q) const {
    if (q + kMsgHeaderSize > d_.size()) return false;
    const size_t size = U16(&d_[q]);
    const uint8_t type = d_[q + 2];
    if (q + kMsgHeaderSize + size > d_.size() || size == 0) return false;
    const uint8_t* p = &d_[q + kMsgHeaderSize];
    switch (type) {
      case 'D': {
        if (size < 2) return false;
        auto it = subs_.find(U16(p));
        if (it == subs_.end()) return false;
        const Topic& t = work_[it->second];
        return size - 2 >= t.record_size && size - 2 <= t.max_record_size;
      }
      case 'L': return size >= 9 && p[0] >= '0' && p[0] <= '7';
      case 'C': return size >= 11 && p[0] >= '0' && p[0] <= '7';
      case 'O': return size == 2;
      case 'R': return size == 2;
      case 'S': return size == 8 && std::memcmp(p, kSyncMagic, 8) == 0;
      case 'A': return size >= 4 && f_.formats.count(std::string(reinterpret_cast<const char*>(p + 3), size - 3)) > 0;
      case 'I':
      case 'P': return size >= 2 && p[0] > 0 && 1u + p[0] <= size;
      case 'M':
      case 'Q': return size >= 3 && p[1] > 0 && 2u + p[1] <= size;
      default: return false;
    }
  }
  bool PlausibleChain(size_t q) const {
    if (!Plausible(q)) return false;
    const size_t next = q + kMsgHeaderSize + U16(&d_[q]);
    return next == d_.size() || Plausible(next);
  }

  // Parses "type key" + value of an info-like payload.
  bool ParseInfo(const uint8_t* p, size_t n, std::string* key, InfoValue* v) {
    if (n < 1) return false;
    const size_t key_len = p[0];
    if (key_len == 0 || 1 + key_len > n) return false;
    const std::string type_key(reinterpret_cast<const char*>(p + 1), key_len);
    const size_t space = type_key.find(' ');
    if (space == std::string::npos || space == 0 || space + 1 == type_key.size()) return false;
    v->type = type_key.substr(0, space);
    *key = type_key.substr(space + 1);
    v->bytes.assign(p + 1 + key_len, p + n);
    BaseType bt;
    if (ParseBaseType(v->type, &bt) && v->bytes.size() != static_cast<size_t>(BaseTypeSize(bt))) return false;
    return true;
  }

  bool ParseParam(const uint8_t* p, size_t n, std::string* key, ParamValue* out) {
    InfoValue v;
    if (!ParseInfo(p, n, key, &v) || v.bytes.size() != 4) return false;
    if (v.type == "int32_t") {
      out->is_float = false;
      out->i = Load<int32_t>(v.bytes.data());
    } else if (v.type == "float") {
      out->is_float = true;
      out->f = Load<float>(v.bytes.data());
    } else {
      return false;
    }
    return true;
  }

  /// One message's header fields and payload; `end` is where the next one starts.
  struct Msg {
    size_t pos;
    size_t size;
    uint8_t type;
    const uint8_t* p;
    size_t end;
  };

  /// Corruption in message m (see Corrupt), described with its type and size.
  size_t Bad(const Msg& m, const std::string& what) {
    return Corrupt(m.pos, m.end, fmt::format("{} ('{}' message, {} bytes)", what, static_cast<char>(m.type), m.size));
  }

  // Decodes the message at pos (known to fit the segment); returns the next position.
  size_t Message(size_t pos) {
    const size_t size = U16(&d_[pos]);
    const Msg m{pos, size, d_[pos + 2], &d_[pos + kMsgHeaderSize], pos + kMsgHeaderSize + size};
    switch (m.type) {
      case 'B': return FlagBits(m);
      case 'F': return FormatDefinition(m);
      case 'I': {
        std::string key;
        InfoValue v;
        if (!ParseInfo(m.p, m.size, &key, &v)) return Bad(m, "malformed info message");
        f_.info[key] = std::move(v);
        return m.end;
      }
      case 'M': return InfoMultiple(m);
      case 'P': return Parameter(m);
      case 'Q': return DefaultParameter(m);
      case 'A': return Subscription(m);
      case 'R': {
        if (m.size != 2) return Bad(m, "unsubscribe message must be 2 bytes");
        subs_.erase(U16(m.p));
        return m.end;
      }
      case 'D': return Data(m);
      case 'L':
      case 'C': return LoggedString(m);
      case 'O': {
        if (m.size != 2) return Bad(m, "dropout message must be 2 bytes");
        f_.dropouts.push_back({f_.last_timestamp_us, U16(m.p)});
        return m.end;
      }
      case 'S': {
        if (m.size != 8 || std::memcmp(m.p, kSyncMagic, 8) != 0) return Bad(m, "sync message with wrong magic");
        ++f_.sync_count;
        return m.end;
      }
      default:
        // The spec lets new message types appear; readers skip them. A type
        // that is not a letter cannot be one, so that is corruption.
        if (m.size > 0 && ((m.type >= 'A' && m.type <= 'Z') || (m.type >= 'a' && m.type <= 'z'))) {
          ++f_.unknown_message_types[static_cast<char>(m.type)];
          return m.end;
        }
        return Corrupt(m.pos, m.end, fmt::format("invalid message type 0x{:02x} ({} bytes)", m.type, m.size));
    }
  }

  /// 'B': compatibility flags (must be the first message) and the appended-data
  /// offsets, which must point forward into the file in increasing order.
  size_t FlagBits(const Msg& m) {
    if (m.pos != kHeaderSize) return Bad(m, "flag bits message is not the first message");
    if (m.size < 40) return Bad(m, "flag bits message too short");
    std::memcpy(f_.compat_flags, m.p, 8);
    std::memcpy(f_.incompat_flags, m.p + 8, 8);
    if ((f_.incompat_flags[0] & ~1) != 0 ||
        std::any_of(f_.incompat_flags + 1, f_.incompat_flags + 8, [](uint8_t b) { return b != 0; })) {
      Fail(m.pos, "unknown incompatible flag set: this ULog cannot be parsed");
    }
    if (f_.incompat_flags[0] & 1) {
      uint64_t prev = 0;
      for (int i = 0; i < 3; ++i) {
        const uint64_t off = U64(m.p + 16 + 8 * i);
        if (off == 0) continue;
        if (opt_.read_to_cut && off > d_.size() && off > m.end && off > prev) {
          ++f_.appended_offsets_past_end;  // the file was cut before its appended data
          continue;
        }
        if (off <= m.end || off > d_.size() || off <= prev) {
          if (!opt_.recover)
            Fail(m.pos, fmt::format("appended-data offset {} outside the file ({} bytes)", off, d_.size()));
          f_.skips.push_back({static_cast<int64_t>(m.pos), 0, fmt::format("ignored appended-data offset {}", off)});
          continue;
        }
        f_.appended_offsets.push_back(off);
        prev = off;
      }
    }
    return m.end;
  }

  /// 'F': a message format "name:type field;type field;...".
  size_t FormatDefinition(const Msg& m) {
    const std::string text(reinterpret_cast<const char*>(m.p), m.size);
    const size_t colon = text.find(':');
    if (colon == std::string::npos || colon == 0) return Bad(m, "format definition without 'name:'");
    MessageFormat mf;
    mf.name = text.substr(0, colon);
    size_t start = colon + 1;
    while (start <= text.size()) {
      size_t semi = text.find(';', start);
      if (semi == std::string::npos) semi = text.size();
      const std::string piece = text.substr(start, semi - start);
      if (!piece.empty()) {
        FormatField ff;
        if (!ParseFormatField(piece, &ff)) return Bad(m, "malformed field '" + piece + "' in format " + mf.name);
        mf.fields.push_back(std::move(ff));
      }
      start = semi + 1;
    }
    f_.formats[mf.name] = std::move(mf);
    return m.end;
  }

  /// 'M': one piece of a multi-part info value; a continuation flag appends it to the last list.
  size_t InfoMultiple(const Msg& m) {
    std::string key;
    InfoValue v;
    if (m.size < 1 || !ParseInfo(m.p + 1, m.size - 1, &key, &v)) return Bad(m, "malformed info_multiple message");
    auto& lists = f_.info_multiple[key];
    if (m.p[0] != 0 && !lists.empty()) {
      lists.back().push_back(std::move(v));
    } else {
      lists.push_back({std::move(v)});
    }
    return m.end;
  }

  /// 'P': a parameter; initial while still in the definitions, else a change at the last timestamp.
  size_t Parameter(const Msg& m) {
    std::string key;
    ParamValue v;
    if (!ParseParam(m.p, m.size, &key, &v)) return Bad(m, "malformed parameter message");
    if (in_definitions_) {
      f_.initial_params[key] = v;
    } else {
      f_.changed_params.push_back({f_.last_timestamp_us, key, v});
    }
    return m.end;
  }

  /// 'Q': a default parameter value for each configuration whose bit is set.
  size_t DefaultParameter(const Msg& m) {
    std::string key;
    ParamValue v;
    if (m.size < 1 || !ParseParam(m.p + 1, m.size - 1, &key, &v)) return Bad(m, "malformed default parameter message");
    for (int bit = 0; bit < 8; ++bit) {
      if (m.p[0] & (1 << bit)) f_.default_params[bit][key] = v;
    }
    return m.end;
  }

  /// 'A': subscribes msg_id to a topic instance; a re-subscription must keep the layout.
  size_t Subscription(const Msg& m) {
    in_definitions_ = false;
    if (m.size < 4) return Bad(m, "subscription message too short");
    const uint8_t multi_id = m.p[0];
    const uint16_t msg_id = U16(m.p + 1);
    const std::string name(reinterpret_cast<const char*>(m.p + 3), m.size - 3);
    Topic t;
    t.name = name;
    t.multi_id = multi_id;
    t.msg_id = msg_id;
    try {
      t.fields = FlattenFormat(f_.formats, name);
    } catch (const std::invalid_argument& e) {
      return Bad(m, fmt::format("subscription to topic '{}': {}", name, e.what()));
    }
    t.max_record_size = t.fields.empty() ? 0 : t.fields.back().offset + BaseTypeSize(t.fields.back().type);
    while (!t.fields.empty() && t.fields.back().name.rfind("_padding", 0) == 0) t.fields.pop_back();
    t.record_size = t.fields.empty() ? 0 : t.fields.back().offset + BaseTypeSize(t.fields.back().type);
    if (t.record_size == 0) return Bad(m, fmt::format("subscription to empty topic '{}'", name));
    for (size_t i = 0; i < t.fields.size(); ++i) {
      if (t.fields[i].name == "timestamp" && t.fields[i].type == BaseType::kUInt64)
        t.timestamp_field = static_cast<int>(i);
    }
    const auto key = std::make_pair(name, static_cast<int>(multi_id));
    auto it = by_name_.find(key);
    if (it != by_name_.end()) {
      Topic& old = work_[it->second];
      if (old.record_size != t.record_size || old.fields.size() != t.fields.size()) {
        return Bad(m, fmt::format("topic '{}' instance {} re-subscribed with another layout", name, multi_id));
      }
      old.msg_id = msg_id;
      subs_[msg_id] = it->second;
    } else {
      work_.push_back(std::move(t));
      by_name_[key] = work_.size() - 1;
      subs_[msg_id] = work_.size() - 1;
    }
    return m.end;
  }

  /// 'D': one record of a subscribed topic (trailing padding dropped); advances the last timestamp.
  size_t Data(const Msg& m) {
    in_definitions_ = false;
    if (m.size < 2) return Bad(m, "data message too short");
    const uint16_t msg_id = U16(m.p);
    auto it = subs_.find(msg_id);
    if (it == subs_.end()) return Bad(m, fmt::format("data for msg_id {} without subscription", msg_id));
    Topic& t = work_[it->second];
    const size_t n = m.size - 2;
    if (n < t.record_size || n > t.max_record_size) {
      return Bad(m, fmt::format("data for topic '{}' has {} bytes, format needs {}", t.name, n, t.record_size));
    }
    t.records.insert(t.records.end(), m.p + 2, m.p + 2 + t.record_size);
    if (t.timestamp_field >= 0) {
      const uint64_t ts = U64(m.p + 2 + t.fields[t.timestamp_field].offset);
      f_.last_timestamp_us = std::max(f_.last_timestamp_us, ts);
    }
    return m.end;
  }

  /// 'L' / 'C': a logged string, the tagged form ('C') carrying a 16-bit tag before the timestamp.
  size_t LoggedString(const Msg& m) {
    in_definitions_ = false;
    const bool tagged = m.type == 'C';
    const size_t text_at = tagged ? 11 : 9;
    if (m.size < text_at)
      return Bad(m, tagged ? "tagged logged string message too short" : "logged string message too short");
    LogMessage lm;
    lm.level = m.p[0];
    if (tagged) {
      lm.tagged = true;
      lm.tag = U16(m.p + 1);
    }
    lm.timestamp_us = U64(m.p + (tagged ? 3 : 1));
    lm.text.assign(reinterpret_cast<const char*>(m.p + text_at), m.size - text_at);
    f_.messages.push_back(std::move(lm));
    return m.end;
  }

  void Finish() {
    for (Topic& t : work_) {
      if (t.size() > 0) f_.topics.push_back(std::move(t));
    }
    std::sort(f_.topics.begin(), f_.topics.end(), [](const Topic& a, const Topic& b) {
      return a.name != b.name ? a.name < b.name : a.multi_id < b.multi_id;
    });
  }

  const std::vector<uint8_t>& d_;
  const std::string& path_;
  ReadOptions opt_;
  UlogFile& f_;
  bool in_definitions_ = true;
  int64_t messages_read_ = 0;  // complete messages so far (a cut reports how many came before it)
  std::vector<Topic> work_;
  std::map<uint16_t, size_t> subs_;
  std::map<std::pair<std::string, int>, size_t> by_name_;
};

}  // namespace

int BaseTypeSize(BaseType t) {
  switch (t) {
    case BaseType::kInt8:
    case BaseType::kUInt8:
    case BaseType::kBool:
    case BaseType::kChar: return 1;
    case BaseType::kInt16:
    case BaseType::kUInt16: return 2;
    case BaseType::kInt32:
    case BaseType::kUInt32:
    case BaseType::kFloat: return 4;
    case BaseType::kInt64:
    case BaseType::kUInt64:
    case BaseType::kDouble: return 8;
  }
  return 1;
}

bool ParseBaseType(const std::string& n, BaseType* out) {
  static const std::pair<const char*, BaseType> kTypes[] = {
      {"int8_t", BaseType::kInt8},     {"uint8_t", BaseType::kUInt8},   {"int16_t", BaseType::kInt16},
      {"uint16_t", BaseType::kUInt16}, {"int32_t", BaseType::kInt32},   {"uint32_t", BaseType::kUInt32},
      {"int64_t", BaseType::kInt64},   {"uint64_t", BaseType::kUInt64}, {"float", BaseType::kFloat},
      {"double", BaseType::kDouble},   {"bool", BaseType::kBool},       {"char", BaseType::kChar}};
  for (const auto& [name, t] : kTypes) {
    if (n == name) {
      *out = t;
      return true;
    }
  }
  return false;
}

const char* BaseTypeName(BaseType t) {
  switch (t) {
    case BaseType::kInt8: return "int8_t";
    case BaseType::kUInt8: return "uint8_t";
    case BaseType::kInt16: return "int16_t";
    case BaseType::kUInt16: return "uint16_t";
    case BaseType::kInt32: return "int32_t";
    case BaseType::kUInt32: return "uint32_t";
    case BaseType::kInt64: return "int64_t";
    case BaseType::kUInt64: return "uint64_t";
    case BaseType::kFloat: return "float";
    case BaseType::kDouble: return "double";
    case BaseType::kBool: return "bool";
    case BaseType::kChar: return "char";
  }
  return "?";
}

std::vector<FlatField> FlattenFormat(const std::map<std::string, MessageFormat>& formats,
                                     const std::string& type_name) {
  Flattener f{formats, {}, 0};
  f.Flatten("", type_name, 0);
  return std::move(f.out);
}

std::optional<size_t> Topic::FieldIndex(const std::string& field_name) const {
  for (size_t i = 0; i < fields.size(); ++i) {
    if (fields[i].name == field_name) return i;
  }
  return std::nullopt;
}

double Topic::Value(size_t row, size_t field) const {
  const FlatField& f = fields[field];
  const uint8_t* p = records.data() + row * record_size + f.offset;
  switch (f.type) {
    case BaseType::kFloat: return Load<float>(p);
    case BaseType::kDouble: return Load<double>(p);
    case BaseType::kUInt64: return static_cast<double>(Load<uint64_t>(p));
    default: return static_cast<double>(IntValue(row, field));
  }
}

int64_t Topic::IntValue(size_t row, size_t field) const {
  const FlatField& f = fields[field];
  const uint8_t* p = records.data() + row * record_size + f.offset;
  switch (f.type) {
    case BaseType::kInt8:
    case BaseType::kChar: return Load<int8_t>(p);
    case BaseType::kUInt8:
    case BaseType::kBool: return Load<uint8_t>(p);
    case BaseType::kInt16: return Load<int16_t>(p);
    case BaseType::kUInt16: return Load<uint16_t>(p);
    case BaseType::kInt32: return Load<int32_t>(p);
    case BaseType::kUInt32: return Load<uint32_t>(p);
    case BaseType::kInt64: return Load<int64_t>(p);
    case BaseType::kUInt64: return static_cast<int64_t>(Load<uint64_t>(p));
    case BaseType::kFloat: {
      const float v = Load<float>(p);
      return std::isfinite(v) && std::fabs(v) < 9e18f ? static_cast<int64_t>(v) : 0;
    }
    case BaseType::kDouble: {
      const double v = Load<double>(p);
      return std::isfinite(v) && std::fabs(v) < 9e18 ? static_cast<int64_t>(v) : 0;
    }
  }
  return 0;
}

uint64_t Topic::UInt64Value(size_t row, size_t field) const {
  if (fields[field].type == BaseType::kUInt64)
    return Load<uint64_t>(records.data() + row * record_size + fields[field].offset);
  return static_cast<uint64_t>(IntValue(row, field));
}

uint64_t Topic::TimestampUs(size_t row) const {
  return timestamp_field < 0 ? 0 : UInt64Value(row, static_cast<size_t>(timestamp_field));
}

std::string InfoValue::ToString() const {
  if (type.rfind("char[", 0) == 0) return std::string(bytes.begin(), bytes.end());
  BaseType bt;
  if (ParseBaseType(type, &bt) && bytes.size() == static_cast<size_t>(BaseTypeSize(bt))) {
    if (bt == BaseType::kFloat) return PythonFloat(Load<float>(bytes.data()));
    if (bt == BaseType::kDouble) return PythonFloat(Load<double>(bytes.data()));
    if (bt == BaseType::kBool) return bytes[0] ? "True" : "False";
    if (bt == BaseType::kUInt64) return std::to_string(Load<uint64_t>(bytes.data()));
    return std::to_string(*AsInt());
  }
  std::string hex;  // arrays of non-char types: raw bytes
  for (uint8_t b : bytes) hex += fmt::format("{:02x}", b);
  return hex;
}

std::optional<int64_t> InfoValue::AsInt() const {
  BaseType bt;
  if (!ParseBaseType(type, &bt) || bytes.size() != static_cast<size_t>(BaseTypeSize(bt))) return std::nullopt;
  const uint8_t* p = bytes.data();
  switch (bt) {
    case BaseType::kInt8:
    case BaseType::kChar: return Load<int8_t>(p);
    case BaseType::kUInt8:
    case BaseType::kBool: return Load<uint8_t>(p);
    case BaseType::kInt16: return Load<int16_t>(p);
    case BaseType::kUInt16: return Load<uint16_t>(p);
    case BaseType::kInt32: return Load<int32_t>(p);
    case BaseType::kUInt32: return Load<uint32_t>(p);
    case BaseType::kInt64: return Load<int64_t>(p);
    case BaseType::kUInt64: return static_cast<int64_t>(Load<uint64_t>(p));
    default: return std::nullopt;
  }
}

const char* LogMessage::LevelName() const {
  static const char* kNames[] = {"EMERGENCY", "ALERT", "CRITICAL", "ERROR", "WARNING", "NOTICE", "INFO", "DEBUG"};
  return level >= '0' && level <= '7' ? kNames[level - '0'] : "UNKNOWN";
}

const Topic* UlogFile::FindTopic(const std::string& name, int multi_id) const {
  for (const Topic& t : topics) {
    if (t.name == name && t.multi_id == multi_id) return &t;
  }
  return nullptr;
}

std::string UlogFile::InfoString(const std::string& key) const {
  auto it = info.find(key);
  return it == info.end() ? std::string() : it->second.ToString();
}

UlogFile ReadUlogFile(std::istream& in, const std::string& path, const ReadOptions& options) {
  const std::vector<uint8_t> data = ReadAll(in);
  if (in.bad()) throw InputError(InputLocation::File(path), "read error");
  UlogFile f;
  Parser(data, path, options, &f).Run();
  return f;
}

UlogFile ReadUlogFile(const std::filesystem::path& path, const ReadOptions& options) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(InputLocation::File(path.string()), "cannot open file");
  return ReadUlogFile(in, path.string(), options);
}

}  // namespace rs::ulog
