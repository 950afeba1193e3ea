#pragma once
// `${ROADSURVEY_DATA}` in a survey file's input paths: the folder of real
// data (a survey file shipped with the code, such as examples/, names its
// inputs relative to it so it runs wherever that folder is).

#include <filesystem>
#include <string>

#include "formats/input_error.h"

namespace rs {

/// The environment variable, written `${ROADSURVEY_DATA}` in input paths.
inline constexpr const char* kDataVariable = "ROADSURVEY_DATA";

/// The folder `${ROADSURVEY_DATA}` stands for, and where that came from.
struct DataRoot {
  std::filesystem::path folder;  ///< absolute, lexically normal
  std::string origin;            ///< for messages: "$ROADSURVEY_DATA" or "the default ..."
};

/// $ROADSURVEY_DATA when set and non-empty (a relative value is relative to
/// the working directory), else the default fixed at build time: ../shared/data
/// beside the source checkout the program was built from.
DataRoot CurrentDataRoot();

/// Replaces every `${ROADSURVEY_DATA}` in `value` by `root.folder`. Throws
/// InputError at `where` for any other `${...}` (nothing else is expanded) and,
/// when the variable occurs, for a root that is not an existing folder.
/// A value without `${` is returned unchanged.
std::string ExpandPathVariables(const std::string& value, const DataRoot& root, const InputLocation& where);

}  // namespace rs
