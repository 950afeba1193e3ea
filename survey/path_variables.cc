#include "survey/path_variables.h"

#include <cstdlib>

namespace rs {
namespace fs = std::filesystem;

#ifndef ROADSURVEY_DATA_DEFAULT
#error "ROADSURVEY_DATA_DEFAULT must be defined by the build (survey/CMakeLists.txt)"
#endif

DataRoot CurrentDataRoot() {
  if (const char* env = std::getenv(kDataVariable); env && *env)
    return {fs::absolute(env).lexically_normal(), std::string("$") + kDataVariable};
  return {fs::path(ROADSURVEY_DATA_DEFAULT).lexically_normal(),
          std::string("the default, ../shared/data beside the checkout; ") + kDataVariable + " is not set"};
}

std::string ExpandPathVariables(const std::string& value, const DataRoot& root, const InputLocation& where) {
  const std::string variable = std::string("${") + kDataVariable + "}";
  std::string out;
  bool used = false;
  for (size_t i = 0; i < value.size();) {
    if (value.compare(i, 2, "${") != 0) {
      out += value[i++];
      continue;
    }
    if (value.compare(i, variable.size(), variable) != 0) {
      const size_t close = value.find('}', i);
      const std::string name = close == std::string::npos ? value.substr(i) : value.substr(i, close - i + 1);
      throw InputError(where,
                       "path \"" + value + "\": unknown variable " + name + " (only " + variable + " is expanded)");
    }
    out += root.folder.string();
    used = true;
    i += variable.size();
  }
  if (used && !fs::is_directory(root.folder))
    throw InputError(where, "path \"" + value + "\" needs " + variable + ", which is " + root.folder.string() + " (" +
                                root.origin + "): not a folder. Set " + kDataVariable +
                                " to the folder holding the data");
  return out;
}

}  // namespace rs
