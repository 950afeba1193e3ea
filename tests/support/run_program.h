#pragma once
// Helpers for end-to-end tests that run the built `roadsurvey` program.

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

namespace rs::test {

/// Path of the built program; $ROADSURVEY_TEST_PROGRAM names another build of it (e.g. an older
/// one, to show that a regression test fails there).
inline std::filesystem::path ProgramPath() {
  if (const char* other = std::getenv("ROADSURVEY_TEST_PROGRAM"); other && *other) return other;
  return std::filesystem::path(ROADSURVEY_BINARY_DIR) / "roadsurvey";
}

struct ProgramResult {
  int exit_code = -1;
  std::string output;  ///< stdout and stderr together
};

/// Runs a shell command line and captures its stdout and stderr together.
inline ProgramResult RunShell(const std::string& command) {
  ProgramResult r;
  const std::string cmd = "(" + command + ") 2>&1";
  FILE* pipe = ::popen(cmd.c_str(), "r");
  if (!pipe) return r;
  std::array<char, 4096> buf;
  size_t n;
  while ((n = std::fread(buf.data(), 1, buf.size(), pipe)) > 0) r.output.append(buf.data(), n);
  const int status = ::pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

/// Runs `prefix roadsurvey <args>` through the shell and captures its output; `prefix` sets the
/// environment or limits (`ulimit -f 600;`, `VAR=value`).
inline ProgramResult RunProgramWith(const std::string& prefix, const std::string& args) {
  return RunShell(prefix + " " + ProgramPath().string() + " " + args);
}

/// Runs `roadsurvey <args>` through the shell and captures its output.
inline ProgramResult RunProgram(const std::string& args) { return RunProgramWith("", args); }

inline nlohmann::json ReadJson(const std::filesystem::path& p) {
  std::ifstream in(p);
  return nlohmann::json::parse(in);
}

inline std::string Slurp(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

}  // namespace rs::test
