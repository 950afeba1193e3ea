#pragma once
namespace rs {
/// Program version, recorded in every manifest.
inline constexpr const char* kRoadsurveyVersion = "0.1.0";
}  // namespace rs
