#pragma once
// Test support: writes small DataFlash logs (FMT records and messages) into a
// byte string so tests can round-trip known content through std::stringstream.

#include <cstdint>
#include "formats/byte_writer.h"
#include <cstring>
#include <string>

namespace rs::dataflash::testing {

using Payload = rs::LittleEndianBytes;

/// Builds a DataFlash byte stream.
class DataflashBuilder {
 public:
  DataflashBuilder() { Fmt(128, 89, "FMT", "BBnNZ", "Type,Length,Name,Format,Columns"); }
  DataflashBuilder& Fmt(uint8_t type, uint8_t length, const std::string& name, const std::string& format,
                        const std::string& columns) {
    return Message(
        128, Payload().Put<uint8_t>(type).Put<uint8_t>(length).Text(name, 4).Text(format, 16).Text(columns, 64).str());
  }
  DataflashBuilder& Message(uint8_t type, const std::string& payload) {
    out_ += "\xA3\x95";
    out_ += static_cast<char>(type);
    out_ += payload;
    return *this;
  }
  DataflashBuilder& Garbage(const std::string& bytes) {
    out_ += bytes;
    return *this;
  }
  size_t size() const { return out_.size(); }
  const std::string& str() const { return out_; }

 private:
  std::string out_;
};

}  // namespace rs::dataflash::testing
