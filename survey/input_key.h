#pragma once
// Keys of the survey's own inputs (frames folder, calibration, flight log, CRS), the roots of
// every cache key. What a run writes into its output folder never changes them, wherever the
// output folder lies (below an input folder, or the input folder itself: `"output": "."`).

#include <string>

#include "survey/hash.h"
#include "survey/stage.h"
#include "survey/survey_file.h"

namespace rs {

/// The survey's output folder and the top-level names a run owns there: work/, manifest.json,
/// every stage's published names, frame-range folders (frames-*) and dot-names (temporaries,
/// locks).
OutputExclusion SurveyOutputExclusion(const StageRegistry& registry, const SurveyFile& survey);

/// Key of a source artifact (kSurveyInputs or kSurveyCrs).
std::string SourceKey(const SurveyFile& survey, const std::string& artifact, const OutputExclusion& output);

}  // namespace rs
