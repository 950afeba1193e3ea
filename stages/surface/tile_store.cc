#include "stages/surface/tile_store.h"

#include <algorithm>
#include <string>

namespace rs {
namespace fs = std::filesystem;

TileStore::TileStore(int tile_cells, int keep, std::vector<int64_t> last_use, fs::path spill_dir)
    : tile_cells_(tile_cells),
      keep_(keep),
      last_use_(std::move(last_use)),
      spill_dir_(std::move(spill_dir)),
      spilled_(last_use_.size(), 0) {}

TileStore::~TileStore() {
  std::error_code ec;
  if (!spill_dir_.empty()) fs::remove_all(spill_dir_, ec);
}

fs::path TileStore::SpillPath(int tile) const { return spill_dir_ / ("tile-" + std::to_string(tile) + ".bin"); }

TileAccumulator& TileStore::Touch(int tile, int64_t seq) {
  auto it = resident_.find(tile);
  if (it == resident_.end()) {
    if (spilled_[tile]) {
      it = resident_.emplace(tile, Resident{TileAccumulator::Load(SpillPath(tile)), seq}).first;
      fs::remove(SpillPath(tile));
      spilled_[tile] = 0;
      ++reloads_;
    } else {
      it = resident_.emplace(tile, Resident{TileAccumulator(tile_cells_, keep_), seq}).first;
    }
    bytes_ += it->second.acc.bytes();
    peak_bytes_ = std::max(peak_bytes_, bytes_);
  }
  it->second.last_touch = seq;
  return it->second.acc;
}

void TileStore::Release(int64_t seq, int keep_frames, const EmitFn& emit) {
  for (auto it = resident_.begin(); it != resident_.end();) {
    const bool finished = last_use_[it->first] <= seq;
    const bool idle = it->second.last_touch <= seq - keep_frames;
    if (!finished && !idle) {
      ++it;
      continue;
    }
    if (finished) {
      emit(it->first, it->second.acc);
    } else {
      fs::create_directories(spill_dir_);
      it->second.acc.Save(SpillPath(it->first));
      spilled_[it->first] = 1;
      ++spills_;
    }
    bytes_ -= it->second.acc.bytes();
    it = resident_.erase(it);
  }
}

void TileStore::Finish(const EmitFn& emit) {
  for (int t = 0; t < static_cast<int>(spilled_.size()); ++t) {
    if (spilled_[t]) {
      emit(t, TileAccumulator::Load(SpillPath(t)));
      fs::remove(SpillPath(t));
      spilled_[t] = 0;
    } else if (auto it = resident_.find(t); it != resident_.end()) {
      emit(t, it->second.acc);
    }
  }
  resident_.clear();
  bytes_ = 0;
}

}  // namespace rs
