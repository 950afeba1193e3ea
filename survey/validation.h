#pragma once
// The one validation pass `validate` and `run` share, so that they cannot disagree: a survey
// that `validate` passes does not fail `run` on its inputs, and `run` refuses up front (exit 2,
// nothing computed) what `validate` reports as an error.

#include <filesystem>

#include <nlohmann/json.hpp>

#include "formats/input_error.h"
#include "survey/stage.h"

namespace rs {

/// A file (not a folder) at the output path or at one of its parents: no run could write there.
void CheckOutputFolder(const std::filesystem::path& output_dir, ProblemList& problems);

/// Checks the output folder, then every stage's inputs with the resolved `options`
/// (stage name -> merged options, see ResolveOptions). An InputError a stage throws is
/// one error of the list.
ProblemList ValidateSurvey(const StageRegistry& registry, const SurveyFile& survey, const nlohmann::json& options,
                           ValidationDepth depth);

}  // namespace rs
