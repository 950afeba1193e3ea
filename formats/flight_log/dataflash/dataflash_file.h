#pragma once
// Generic reader of ArduPilot DataFlash logs (.bin): every message is decoded
// through the FMT definitions found in the log itself; FMTU/UNIT/MULT, where
// present, attach units and multipliers to the columns. The stream is
// self-resynchronising (each message starts with 0xA3 0x95), so garbage is
// skipped and counted rather than fatal. Details: docs/formats/binary-logs.md.

#include <cstdint>
#include <filesystem>
#include <istream>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace rs::dataflash {

/// Bytes of one value of an ArduPilot format character, 0 if unknown.
/// Known: b B h H i I f d n N Z c C e E L M q Q a.
int FormatCharSize(char c);
/// Scale implied by the format character: 0.01 for c C e E (centi-units),
/// 1e-7 for L (lat/lon), 1 otherwise.
double FormatCharScale(char c);

/// One column of a message type.
struct Column {
  std::string name;
  char type = 0;               ///< ArduPilot format character
  uint32_t offset = 0;         ///< byte offset inside the payload (after the 3-byte header)
  std::string unit;            ///< from FMTU/UNIT, "" if the log has none
  double fmtu_multiplier = 0;  ///< from FMTU/MULT (documentation only; 0 if none)
};

/// A message type as declared by an FMT record, with all its decoded records.
struct MessageType {
  uint8_t type = 0;
  uint8_t length = 0;  ///< total message length including the 3-byte header
  std::string name;
  std::string format;  ///< format characters
  std::vector<Column> columns;
  std::vector<uint8_t> payloads;  ///< size() * (length - 3) bytes, as in the file
  std::vector<int64_t> offsets;   ///< byte offset of each record in the file

  size_t payload_size() const { return length > 3 ? length - 3u : 0u; }
  size_t size() const { return payload_size() ? payloads.size() / payload_size() : 0; }
  /// Index of a column by name.
  std::optional<size_t> ColumnIndex(const std::string& column) const;
  /// Numeric value with the format character's implied scale applied
  /// (degrees for L, units for c/C/e/E); NaN for text and array columns.
  double Value(size_t row, size_t column) const;
  /// Raw integer value (no scaling); 0 for non-integer columns.
  int64_t Int(size_t row, size_t column) const;
  /// Text of an n/N/Z column, trailing NULs removed.
  std::string Text(size_t row, size_t column) const;
};

/// A run of bytes that could not be decoded.
struct Skip {
  int64_t offset = 0;
  int64_t bytes = 0;
  std::string reason;
};

/// The decoded content of a DataFlash log.
struct DataflashFile {
  std::vector<MessageType> types;         ///< in order of first definition
  std::map<std::string, size_t> by_name;  ///< name -> index in types (latest definition)
  std::vector<Skip> skips;                ///< first kMaxRecordedSkips runs of skipped bytes
  int64_t skipped_bytes = 0;              ///< all skipped bytes (incl. a truncated tail)
  int64_t skip_runs = 0;                  ///< number of skipped runs
  int rejected_formats = 0;               ///< FMT records that could not be used (unknown chars, bad length)

  static constexpr size_t kMaxRecordedSkips = 100;

  /// Message type by name; nullptr if absent or without records.
  const MessageType* Find(const std::string& name) const;
};

/// Reads a DataFlash log from a stream; `path` names it in errors. Throws
/// rs::InputError (byte offset 0) when nothing in it is a DataFlash message.
DataflashFile ReadDataflashFile(std::istream& in, const std::string& path);
/// Reads a DataFlash log file.
DataflashFile ReadDataflashFile(const std::filesystem::path& path);

}  // namespace rs::dataflash
