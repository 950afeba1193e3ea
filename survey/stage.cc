#include "survey/stage.h"

#include <fmt/format.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <atomic>

#include "formats/checked_file.h"
#include "survey/atomic_file.h"

namespace rs {
namespace fs = std::filesystem;

nlohmann::json StageSummary::ToJson() const {
  return {{"counts", counts},
          {"timings_s", timings_s},
          {"warnings", warnings},
          {"frames",
           {{"total", frames_total},
            {"computed", frames_computed},
            {"reused", frames_reused},
            {"skipped", frames_skipped},
            {"skip_reasons", skip_reasons}}}};
}

StageSummary StageSummary::FromJson(const nlohmann::json& j) {
  StageSummary s;
  s.counts = j.value("counts", nlohmann::json::object());
  s.timings_s = j.value("timings_s", nlohmann::json::object());
  s.warnings = j.value("warnings", std::vector<std::string>{});
  const auto frames = j.value("frames", nlohmann::json::object());
  s.frames_total = frames.value("total", int64_t{0});
  s.frames_computed = frames.value("computed", int64_t{0});
  s.frames_reused = frames.value("reused", int64_t{0});
  s.frames_skipped = frames.value("skipped", int64_t{0});
  s.skip_reasons = frames.value("skip_reasons", std::map<std::string, int64_t>{});
  return s;
}

StageContext::StageContext(std::string stage_name, const SurveyFile& survey, fs::path out_dir,
                           std::map<std::string, fs::path> input_dirs, FrameSelection frames, int threads,
                           Progress& progress)
    : stage_name_(std::move(stage_name)),
      survey_(survey),
      out_dir_(std::move(out_dir)),
      input_dirs_(std::move(input_dirs)),
      frames_(frames),
      threads_(threads),
      progress_(progress) {}

const fs::path& StageContext::input_dir(const std::string& artifact) const {
  const auto it = input_dirs_.find(artifact);
  if (it == input_dirs_.end())
    throw std::logic_error(fmt::format("stage asked for artifact '{}' it did not declare as an input", artifact));
  return it->second;
}

fs::path StageContext::FrameDirIn(const fs::path& stage_dir, FrameId id) {
  return stage_dir / "frames" / fmt::format("{:06d}", id.value);
}

fs::path StageContext::FrameDir(FrameId id) const { return FrameDirIn(out_dir_, id); }

void StageContext::ForEachFrame(const std::vector<FrameRecord>& frames, const FrameFn& fn, bool skip_failed) {
  std::vector<const FrameRecord*> todo;
  int64_t selected = 0, reused = 0;
  for (size_t i = 0; i < frames.size(); ++i) {
    if (!frames_.Contains(frames[i].id.value)) continue;
    ++selected;
    const fs::path dir = FrameDir(frames[i].id);
    if (fs::exists(dir / "skipped.json")) {
      // Skipped in an earlier (interrupted) run: still skipped, and still reported.
      std::lock_guard lock(mutex_);
      ++summary_.frames_skipped;
      ++summary_.skip_reasons[ReadJsonFile(dir / "skipped.json").value("reason", std::string("?"))];
    } else if (fs::exists(dir)) {
      ++reused;
    } else {
      todo.push_back(&frames[i]);
    }
  }
  {
    std::lock_guard lock(mutex_);
    summary_.frames_total += selected;
    summary_.frames_reused += reused;
  }
  fs::create_directories(out_dir_ / "frames");
  progress_.Start(stage_name_, static_cast<int64_t>(todo.size()));

  std::exception_ptr first_error;
  std::atomic<bool> stop{false};
  tbb::task_arena arena(std::max(1, threads_));
  arena.execute([&] {
    tbb::parallel_for(size_t{0}, todo.size(), [&](size_t i) {
      if (stop) return;
      const FrameRecord& frame = *todo[i];
      const fs::path final_dir = FrameDir(frame.id);
      const fs::path tmp_dir = TemporarySibling(final_dir);
      fs::create_directories(tmp_dir);
      try {
        FrameOutcome outcome = fn(frame, tmp_dir);
        CommitDirectory(tmp_dir, final_dir);
        std::lock_guard lock(mutex_);
        ++summary_.frames_computed;
        for (const auto& [k, v] : outcome.counts.items())
          summary_.counts[k] = summary_.counts.value(k, 0.0) + v.get<double>();
        for (auto& w : outcome.warnings) summary_.warnings.push_back(fmt::format("frame {}: {}", frame.id.value, w));
      } catch (const InputError& e) {
        if (!skip_failed) {
          std::error_code ec;
          fs::remove_all(tmp_dir, ec);
          std::lock_guard lock(mutex_);
          if (!first_error) first_error = std::current_exception();
          stop = true;
          return;
        }
        // A skipped frame is cached too (skipped.json), so a resume does not retry it
        // and the skip stays visible in every later summary.
        WriteJsonAtomic(tmp_dir / "skipped.json",
                        {{"frame", frame.id.value}, {"reason", e.message()}, {"where", e.where().ToString()}});
        CommitDirectory(tmp_dir, final_dir);
        std::lock_guard lock(mutex_);
        ++summary_.frames_skipped;
        ++summary_.skip_reasons[e.message()];
        summary_.warnings.push_back(fmt::format("frame {} skipped: {}", frame.id.value, e.what()));
      } catch (const WriteError& e) {
        // Name the file as it would have been committed, not its temporary folder.
        std::error_code ec;
        fs::remove_all(tmp_dir, ec);
        const fs::path rel = e.path().lexically_relative(tmp_dir);
        std::lock_guard lock(mutex_);
        if (!first_error)
          first_error = std::make_exception_ptr(
              rel.empty() || *rel.begin() == ".." ? e : WriteError(final_dir / rel, e.reason()));
        stop = true;
        return;
      } catch (...) {
        std::error_code ec;
        fs::remove_all(tmp_dir, ec);
        std::lock_guard lock(mutex_);
        if (!first_error) first_error = std::current_exception();
        stop = true;
        return;
      }
      progress_.Advance();
    });
  });
  progress_.Finish();
  if (first_error) std::rethrow_exception(first_error);
}

void StageContext::Warn(std::string message) {
  std::lock_guard lock(mutex_);
  summary_.warnings.push_back(std::move(message));
}

void StageContext::Count(const std::string& name, double value) {
  std::lock_guard lock(mutex_);
  summary_.counts[name] = value;
}

void StageContext::Time(const std::string& step, double seconds) {
  std::lock_guard lock(mutex_);
  summary_.timings_s[step] = summary_.timings_s.value(step, 0.0) + seconds;
}

void StageRegistry::Add(std::unique_ptr<Stage> stage) {
  if (Find(stage->info().name)) throw std::logic_error(fmt::format("stage '{}' registered twice", stage->info().name));
  stages_.push_back(std::move(stage));
}

const Stage* StageRegistry::Find(const std::string& name) const {
  for (const auto& s : stages_)
    if (s->info().name == name) return s.get();
  return nullptr;
}

const Stage& StageRegistry::Get(const std::string& name) const {
  if (const Stage* s = Find(name)) return *s;
  std::string known;
  for (const auto& s : stages_) known += (known.empty() ? "" : ", ") + s->info().name;
  throw OptionError(fmt::format("unknown stage '{}' (known: {})", name, known));
}

}  // namespace rs
