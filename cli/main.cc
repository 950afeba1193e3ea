// roadsurvey: offline photogrammetric road-damage survey processor.
// Exit codes: 0 success, 1 processing or environment failure (write error, disk full, output
// folder in use), 2 bad input or usage.
#include <fmt/format.h>
#include <malloc.h>
#include <signal.h>
#include <spdlog/spdlog.h>

#include "cli/command.h"
#include "formats/input_error.h"
#include "survey/options.h"
#include "survey/stage.h"
#include "survey/survey_file.h"
#include "survey/version.h"

namespace rs {

const std::vector<Command>& Commands() {
  static const std::vector<Command> commands = {RunCommand(),    ValidateCommand(), StatusCommand(), StagesCommand(),
                                                SchemaCommand(), SimulateCommand(), StereoCommand(), SegmentCommand(),
                                                EvalCommand(),   BenchCommand(),    LogCommand()};
  return commands;
}

}  // namespace rs

int main(int argc, char** argv) {
  using namespace rs;
  // Per-frame images (1-4 MB each) are allocated and freed many times a frame. With glibc's
  // defaults each went to a fresh mmap or was trimmed back to the kernel on free, and every
  // new image page-faulted in again: ~10 % of the damage stage's CPU (bench damage). Kept in
  // the heap instead, freed pages are reused (the process keeps its peak heap).
  mallopt(M_MMAP_THRESHOLD, 256 << 20);
  mallopt(M_TRIM_THRESHOLD, 512 << 20);
  // Over a file-size limit (ulimit -f) the kernel would kill us with SIGXFSZ before the write
  // could fail; ignored, the write fails with EFBIG and the checked writer names the file.
  ::signal(SIGXFSZ, SIG_IGN);
  spdlog::set_pattern("[%H:%M:%S] %^%l%$ %v");
  StageRegistry registry;
  RegisterBuiltinStages(registry);

  CLI::App app{"roadsurvey: stereo drone frames + flight log -> road mesh and georeferenced damage"};
  app.set_version_flag("--version", kRoadsurveyVersion);
  app.require_subcommand(1);
  bool verbose = false;
  app.add_flag("-v,--verbose", verbose, "debug logging");
  std::function<int()> action;
  for (const auto& command : Commands()) {
    CLI::App* sub = app.add_subcommand(command.name, command.description);
    auto run = command.setup(*sub, registry);
    sub->callback([&action, run] { action = run; });
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? kExitOk : kExitBadInput;
  }
  if (verbose) spdlog::set_level(spdlog::level::debug);
  try {
    return action();
  } catch (const ConfigError& e) {
    fmt::print(stderr, "error: {}\n", e.what());
  } catch (const InputError& e) {
    fmt::print(stderr, "error: {}\n", e.what());
  } catch (const OptionError& e) {
    fmt::print(stderr, "error: {}\n", e.what());
  } catch (const std::exception& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return kExitProcessing;
  }
  return kExitBadInput;
}
