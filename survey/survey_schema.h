#pragma once
// The JSON Schema of survey.json, built from the stage registry so that
// schemas/survey.schema.json can never drift from the code (a test compares them).

#include <nlohmann/json.hpp>

namespace rs {

class StageRegistry;

/// Layouts and log formats ingest understands; the schema enumerates them.
extern const char* const kFrameLayouts[];
extern const char* const kFlightLogFormats[];

nlohmann::json BuildSurveySchema(const StageRegistry& registry);

}  // namespace rs
