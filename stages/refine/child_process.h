#pragma once
// Running an external program (no shell) with its stdout and stderr captured line by line.

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace rs {

/// `name` itself when it contains a '/', else the first executable `name` in PATH; nullopt if none.
std::optional<std::filesystem::path> FindProgram(const std::string& name);

struct ChildResult {
  int exit_code = -1;    ///< the program's exit status; -1 when a signal ended it
  int signal = 0;        ///< the signal that ended it, 0 if none
  std::string output;    ///< stdout and stderr, interleaved as written
};

/// Runs `program` with `args` (fork and exec, no shell), both output streams into one pipe;
/// `on_line` sees each output line as it arrives. The child is killed if this process dies.
/// Throws std::system_error when it cannot fork; a program that cannot be executed exits 127.
ChildResult RunChild(const std::filesystem::path& program, const std::vector<std::string>& args,
                     const std::function<void(std::string_view line)>& on_line);

/// The command line as text, for logs and error messages.
std::string CommandLine(const std::filesystem::path& program, const std::vector<std::string>& args);

}  // namespace rs
