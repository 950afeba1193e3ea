#pragma once
// Loading a survey file for a command, with errors printed the same way everywhere.

#include <filesystem>

#include "survey/survey_file.h"

namespace rs {
class StageRegistry;

/// Loads and schema-validates `path` against the registry's schema.
SurveyFile LoadSurveyForCommand(const std::filesystem::path& path, const StageRegistry& registry);

}  // namespace rs
