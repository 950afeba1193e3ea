// roadsurvey stages [NAME] [--markdown]: every stage, its artifacts and options.
#include <fmt/format.h>

#include "cli/command.h"
#include "survey/job_graph.h"
#include "survey/stage.h"

namespace rs {
namespace {

std::string Join(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : ", ") + x;
  return s.empty() ? "-" : s;
}

void PrintText(const Stage& stage) {
  const StageInfo& info = stage.info();
  fmt::print("{} (version {}{})\n  {}\n  inputs:  {}\n  outputs: {}\n", info.name, info.version,
             info.per_frame ? ", per frame" : "", info.doc, Join(info.inputs), Join(info.outputs));
  for (const auto& p : info.published) fmt::print("  publishes: {}\n", p.to);
  for (const auto& spec : stage.options().specs())
    fmt::print("  --{}.{} = {}\n      {}{} ({})\n", info.name, spec.name, spec.default_value.dump(), spec.doc,
               spec.unit.empty() ? "" : " [" + spec.unit + "]", spec.AllowedText());
  fmt::print("\n");
}

void PrintMarkdown(const Stage& stage) {
  const StageInfo& info = stage.info();
  fmt::print("| option (survey.json `stages.{}.<name>`, CLI `--{}.<name>`) | default | allowed | meaning |\n",
             info.name, info.name);
  fmt::print("|---|---|---|---|\n");
  for (const auto& spec : stage.options().specs())
    fmt::print("| `{}` | `{}` | {} | {}{} |\n", spec.name, spec.default_value.dump(), spec.AllowedText(), spec.doc,
               spec.unit.empty() ? "" : " [" + spec.unit + "]");
}

}  // namespace

Command StagesCommand() {
  return {"stages", "List the stages, their inputs, outputs and every option with its default",
          [](CLI::App& app, const StageRegistry& registry) -> std::function<int()> {
            struct Args {
              std::string name;
              bool markdown = false, dot = false;
            };
            auto args = std::make_shared<Args>();
            app.add_option("name", args->name, "only this stage");
            app.add_flag("--markdown", args->markdown, "the options as a Markdown table (for docs/stages/)");
            app.add_flag("--dot", args->dot, "the job graph in Graphviz dot");
            return [args, &registry] {
              if (args->dot) {
                fmt::print("{}", JobGraph::Build(registry).Dot());
                return kExitOk;
              }
              const JobGraph graph = JobGraph::Build(registry);  // order() refers into it: keep it alive
              for (const Stage* stage : graph.order()) {
                if (!args->name.empty() && stage->info().name != args->name) continue;
                args->markdown ? PrintMarkdown(*stage) : PrintText(*stage);
              }
              if (!args->name.empty()) registry.Get(args->name);  // unknown name: error listing the known ones
              return kExitOk;
            };
          }};
}

}  // namespace rs
