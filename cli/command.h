#pragma once
// The `roadsurvey` command table: each subcommand is a thin adapter in its own
// file that parses flags and calls library code.

#include <CLI/CLI.hpp>

#include <functional>
#include <string>
#include <vector>

namespace rs {

class StageRegistry;

/// Exit codes: 0 success, 1 processing failure, 2 bad input or usage.
enum ExitCode { kExitOk = 0, kExitProcessing = 1, kExitBadInput = 2 };

/// A subcommand: `setup` declares its flags on `app` and returns the action to run after parsing.
struct Command {
  std::string name;
  std::string description;
  std::function<std::function<int()>(CLI::App& app, const StageRegistry& registry)> setup;
};

/// Every subcommand, in the order `roadsurvey --help` lists them.
const std::vector<Command>& Commands();

/// Each command's factory (one per cmd_*.cc).
Command RunCommand();
Command ValidateCommand();
Command StatusCommand();
Command StagesCommand();
Command SchemaCommand();
Command SimulateCommand();
Command StereoCommand();
Command SegmentCommand();
Command EvalCommand();
Command BenchCommand();
Command LogCommand();

/// Registers every built-in stage, in pipeline order.
void RegisterBuiltinStages(StageRegistry& registry);

}  // namespace rs
