#pragma once
// Test support: writes small ULog files message by message, so tests can build
// logs with known content (and known corruption) in a std::stringstream.

#include <cstdint>
#include "formats/byte_writer.h"
#include <cstring>
#include <string>
#include <vector>

namespace rs::ulog::testing {

using Bytes = rs::LittleEndianBytes;

/// Builds a ULog byte stream.
class UlogBuilder {
 public:
  explicit UlogBuilder(uint64_t start_us, uint8_t version = 1) {
    out_.append("\x55\x4c\x6f\x67\x01\x12\x35", 7);
    out_ += static_cast<char>(version);
    out_ += Bytes().Put<uint64_t>(start_us).str();
  }
  /// Any message: 3-byte header + payload.
  UlogBuilder& Raw(char type, const std::string& payload) {
    out_ += Bytes().Put<uint16_t>(static_cast<uint16_t>(payload.size())).str();
    out_ += type;
    out_ += payload;
    return *this;
  }
  UlogBuilder& Flags(uint8_t incompat0, uint64_t off0 = 0, uint64_t off1 = 0) {
    Bytes b;
    for (int i = 0; i < 8; ++i) b.Put<uint8_t>(0);
    b.Put<uint8_t>(incompat0);
    for (int i = 0; i < 7; ++i) b.Put<uint8_t>(0);
    b.Put<uint64_t>(off0).Put<uint64_t>(off1).Put<uint64_t>(0);
    return Raw('B', b.str());
  }
  UlogBuilder& Format(const std::string& def) { return Raw('F', def); }
  static std::string InfoPayload(const std::string& type_key, const std::string& value) {
    return Bytes().Put<uint8_t>(static_cast<uint8_t>(type_key.size())).Str(type_key).Str(value).str();
  }
  UlogBuilder& Info(const std::string& key, const std::string& value) {
    return Raw('I', InfoPayload("char[" + std::to_string(value.size()) + "] " + key, value));
  }
  UlogBuilder& InfoInt32(const std::string& key, int32_t v) {
    return Raw('I', InfoPayload("int32_t " + key, Bytes().Put(v).str()));
  }
  UlogBuilder& InfoMultiple(bool continued, const std::string& key, const std::string& value) {
    return Raw('M', std::string(1, continued ? 1 : 0) +
                        InfoPayload("char[" + std::to_string(value.size()) + "] " + key, value));
  }
  UlogBuilder& ParamInt(const std::string& name, int32_t v) {
    return Raw('P', InfoPayload("int32_t " + name, Bytes().Put(v).str()));
  }
  UlogBuilder& ParamFloat(const std::string& name, float v) {
    return Raw('P', InfoPayload("float " + name, Bytes().Put(v).str()));
  }
  UlogBuilder& DefaultParamFloat(uint8_t bits, const std::string& name, float v) {
    return Raw('Q', std::string(1, static_cast<char>(bits)) + InfoPayload("float " + name, Bytes().Put(v).str()));
  }
  UlogBuilder& Subscribe(uint8_t multi_id, uint16_t msg_id, const std::string& name) {
    return Raw('A', Bytes().Put(multi_id).Put(msg_id).Str(name).str());
  }
  UlogBuilder& Data(uint16_t msg_id, const std::string& record) {
    return Raw('D', Bytes().Put(msg_id).Str(record).str());
  }
  UlogBuilder& Log(char level, uint64_t t_us, const std::string& text) {
    return Raw('L', Bytes().Put<uint8_t>(static_cast<uint8_t>(level)).Put(t_us).Str(text).str());
  }
  UlogBuilder& Tagged(char level, uint16_t tag, uint64_t t_us, const std::string& text) {
    return Raw('C', Bytes().Put<uint8_t>(static_cast<uint8_t>(level)).Put(tag).Put(t_us).Str(text).str());
  }
  UlogBuilder& Dropout(uint16_t ms) { return Raw('O', Bytes().Put(ms).str()); }
  UlogBuilder& Sync() { return Raw('S', std::string("\x2F\x73\x13\x20\x25\x0C\xBB\x12", 8)); }
  /// Appends raw bytes (garbage, padding up to an appended-data offset).
  UlogBuilder& Garbage(const std::string& bytes) {
    out_ += bytes;
    return *this;
  }
  size_t size() const { return out_.size(); }
  const std::string& str() const { return out_; }

 private:
  std::string out_;
};

}  // namespace rs::ulog::testing
