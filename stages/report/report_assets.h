#pragma once
// The report's own page, script and stylesheet (stages/report/assets/), compiled into the program
// by embed_assets.cmake so a report can be written wherever roadsurvey is installed.

#include <cstddef>
#include <span>

namespace rs {

struct ReportAsset {
  const char* name;            ///< path inside the report folder, e.g. "report.js"
  const unsigned char* bytes;  ///< the file's content
  size_t size;
};

/// Every asset, in the order of the build's list.
std::span<const ReportAsset> ReportAssets();

}  // namespace rs
