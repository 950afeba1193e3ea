#pragma once
// Generic reader of PX4 ULog files (.ulg), written from the format spec
// (docs.px4.io "ULog File Format"): header, flag bits with appended-data
// offsets, format definitions (nested types, arrays, padding), subscriptions
// with multi_id, data records, info / info_multiple, parameters (initial,
// default, changed), logged strings (plain and tagged), dropouts and sync.
// What is read and how corruption is reported: docs/formats/binary-logs.md.

#include <cstdint>
#include <filesystem>
#include <istream>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace rs::ulog {

/// Scalar type of one flattened field.
enum class BaseType { kInt8, kUInt8, kInt16, kUInt16, kInt32, kUInt32, kInt64, kUInt64, kFloat, kDouble, kBool, kChar };

/// Size in bytes of a base type.
int BaseTypeSize(BaseType t);
/// Parses "int8_t", "float", ...; false for anything else (a nested type name).
bool ParseBaseType(const std::string& name, BaseType* out);
/// The ULog spelling of a base type ("uint64_t").
const char* BaseTypeName(BaseType t);

/// One field of a format definition as written in the file ("float[4] q").
struct FormatField {
  std::string type_name;  ///< base type or name of another format
  int array_size = 0;     ///< 0 for a scalar, n for "type[n]"
  std::string name;
};

/// A format definition ('F' message): "name:type field;type field;...".
struct MessageFormat {
  std::string name;
  std::vector<FormatField> fields;
};

/// One scalar of a flattened record, named like pyulog ("q[0]", "pos.x",
/// "arr[1].y"), at a byte offset inside the record.
struct FlatField {
  std::string name;
  BaseType type = BaseType::kUInt8;
  uint32_t offset = 0;
};

/// All records logged for one topic instance (name + multi_id). Records are
/// stored packed, exactly as in the file (little-endian, no alignment).
struct Topic {
  std::string name;
  uint8_t multi_id = 0;
  uint16_t msg_id = 0;            ///< msg_id of its (last) subscription
  std::vector<FlatField> fields;  ///< trailing _padding fields removed, as pyulog does
  uint32_t record_size = 0;       ///< sum of the field sizes (bytes stored per record)
  uint32_t max_record_size = 0;   ///< record_size plus trailing padding (largest accepted data message)
  std::vector<uint8_t> records;   ///< size() * record_size bytes

  /// Number of records.
  size_t size() const { return record_size ? records.size() / record_size : 0; }
  /// Index of a flattened field by name.
  std::optional<size_t> FieldIndex(const std::string& field_name) const;
  /// Value of field `field` in record `row`, converted to double.
  double Value(size_t row, size_t field) const;
  /// Integer value (exact for all integer types; floats truncated).
  int64_t IntValue(size_t row, size_t field) const;
  /// Exact value of an uint64 field (e.g. timestamps, time_utc_usec).
  uint64_t UInt64Value(size_t row, size_t field) const;
  /// The record's "timestamp" field (microseconds since boot); 0 if the topic has none.
  uint64_t TimestampUs(size_t row) const;

  int timestamp_field = -1;  ///< index of "timestamp" in fields, -1 if absent
};

/// An info ('I') or info_multiple ('M') value, kept with its declared type.
struct InfoValue {
  std::string type;            ///< e.g. "char[12]", "int32_t", "uint8_t[256]"
  std::vector<uint8_t> bytes;  ///< raw value bytes
  /// The value as text: strings verbatim, scalars like Python prints them.
  std::string ToString() const;
  /// Scalar integer value, if the type is an integer type of matching size.
  std::optional<int64_t> AsInt() const;
};

/// A parameter value (parameters are int32_t or float in ULog).
struct ParamValue {
  bool is_float = false;
  int32_t i = 0;
  float f = 0;
  double AsDouble() const { return is_float ? f : i; }
};

/// A parameter change logged in the data section.
struct ParamChange {
  uint64_t timestamp_us = 0;  ///< last data timestamp seen before the change (as pyulog)
  std::string name;
  ParamValue value;
};

/// A logged string ('L' or tagged 'C').
struct LogMessage {
  uint8_t level = 0;  ///< ASCII '0' (emergency) .. '7' (debug)
  bool tagged = false;
  uint16_t tag = 0;  ///< only for tagged messages
  uint64_t timestamp_us = 0;
  std::string text;
  /// "EMERGENCY" .. "DEBUG", "UNKNOWN" for other bytes.
  const char* LevelName() const;
};

/// A dropout ('O'): the logger lost `duration_ms` of data.
struct Dropout {
  uint64_t timestamp_us = 0;  ///< last data timestamp before it
  uint16_t duration_ms = 0;
};

/// A stretch of the file that was not decoded.
struct Skip {
  int64_t offset = 0;  ///< byte offset where the problem was found
  int64_t bytes = 0;   ///< bytes skipped from there
  std::string reason;
};

/// How to treat a corrupt or truncated file.
struct ReadOptions {
  /// false: throw rs::InputError at the first inconsistency (default).
  /// true: skip to the next sync marker (or a plausible message header) and
  /// record each skipped stretch in UlogFile::skips.
  bool recover = false;
  /// true: a file that ends inside a message (the logger lost power) is read up to its last
  /// complete message and the cut is recorded in UlogFile::cut instead of failing.
  bool read_to_cut = false;
};

/// Where a file that ends inside a message was cut, and how much came before it.
struct CutShort {
  int64_t offset = 0;         ///< byte where the incomplete message starts (= bytes read)
  int64_t file_bytes = 0;     ///< size of the file
  int64_t messages_read = 0;  ///< complete messages before the cut (header excluded)
  std::string reason;         ///< "truncated message: needs N bytes, M remain"
};

/// The decoded content of a ULog file.
struct UlogFile {
  uint8_t version = 0;
  uint64_t start_timestamp_us = 0;  ///< from the file header
  uint64_t last_timestamp_us = 0;   ///< largest data timestamp (>= start), as pyulog computes it
  uint8_t compat_flags[8] = {};
  uint8_t incompat_flags[8] = {};
  std::vector<uint64_t> appended_offsets;  ///< non-zero appended-data offsets from the flag bits
  std::map<std::string, MessageFormat> formats;
  std::map<std::string, InfoValue> info;
  std::map<std::string, std::vector<std::vector<InfoValue>>> info_multiple;  ///< key -> list of (continued) value lists
  std::map<std::string, ParamValue> initial_params;
  std::map<int, std::map<std::string, ParamValue>> default_params;  ///< bit index (0 system, 1 current setup) -> params
  std::vector<ParamChange> changed_params;
  std::vector<LogMessage> messages;  ///< plain and tagged, in file order
  std::vector<Dropout> dropouts;
  int sync_count = 0;
  std::vector<Topic> topics;                  ///< sorted by (name, multi_id)
  std::vector<Skip> skips;                    ///< recovery mode: what was skipped and why
  std::map<char, int> unknown_message_types;  ///< unknown (future) message types skipped, by type letter
  int messages_cut_at_appended_offset = 0;    ///< messages cut where appended data starts (normal for crash dumps)
  std::optional<CutShort> cut;                ///< read_to_cut: the file ended inside a message
  int appended_offsets_past_end = 0;          ///< read_to_cut: appended data announced beyond the cut

  /// Topic by name and instance; nullptr if absent.
  const Topic* FindTopic(const std::string& name, int multi_id = 0) const;
  /// Info value as a string ("" if absent).
  std::string InfoString(const std::string& key) const;
};

/// Reads a ULog from a stream; `path` names the input in errors.
/// Throws rs::InputError with InputLocation::Byte(path, offset) on bad input
/// (unless options.recover, which turns data-section corruption into skips).
UlogFile ReadUlogFile(std::istream& in, const std::string& path, const ReadOptions& options = {});
/// Reads a ULog file from disk.
UlogFile ReadUlogFile(const std::filesystem::path& path, const ReadOptions& options = {});

/// Flattens format `type_name` into scalars like pyulog does. Throws
/// std::invalid_argument on an undefined or recursive type, or a record larger
/// than 64 KiB (no ULog message can carry it).
std::vector<FlatField> FlattenFormat(const std::map<std::string, MessageFormat>& formats, const std::string& type_name);

}  // namespace rs::ulog
