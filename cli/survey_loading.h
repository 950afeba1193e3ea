#pragma once
// Loading a survey file for a command, with errors printed the same way everywhere.

#include <filesystem>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "survey/survey_file.h"

namespace rs {
class StageRegistry;

/// Loads and schema-validates `path` against the registry's schema; a non-empty `output`
/// (--output) replaces the survey file's "output".
SurveyFile LoadSurveyForCommand(const std::filesystem::path& path, const StageRegistry& registry,
                                const std::string& output = "");

/// --output's rule (the survey file's "output" has minLength 1): "" would silently mean "not given".
CLI::Validator NonEmptyFolderName();

/// `run`'s up-front pass: the checks `validate` makes, except decoding every image (a run skips
/// bad frames one by one). Prints the problems and returns false when any is an error; prints
/// nothing otherwise (the stages report their own warnings as they run).
bool CheckBeforeRun(const StageRegistry& registry, const SurveyFile& survey, const nlohmann::json& cli_overrides);

}  // namespace rs
