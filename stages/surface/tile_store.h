#pragma once
// The tiles of the height grid that frames are being fused into. A tile stays in memory while the
// flight is over it; when the flight moves on it is either finished (no later frame sees it) and
// handed to the writer, or spilled to disk until a later pass over the same road (a loop, a
// return leg) needs it again. Peak memory is therefore a few frames' footprints, whatever the
// survey's length.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <vector>

#include "stages/surface/tile_accumulator.h"

namespace rs {

class TileStore {
 public:
  /// `last_use[t]`: sequence number of the last frame that sees tile t (-1: none).
  TileStore(int tile_cells, int keep, std::vector<int64_t> last_use, std::filesystem::path spill_dir);
  ~TileStore();

  /// The tile's accumulator, created or brought back from disk; marks it used by frame `seq`.
  TileAccumulator& Touch(int tile, int64_t seq);

  using EmitFn = std::function<void(int tile, const TileAccumulator&)>;
  /// After frame `seq`: hands every finished tile to `emit` and frees it; spills the tiles no frame
  /// in (seq - keep_frames, seq] touched.
  void Release(int64_t seq, int keep_frames, const EmitFn& emit);
  /// Hands every remaining tile (resident or spilled) to `emit`, in tile order.
  void Finish(const EmitFn& emit);

  size_t peak_resident_bytes() const { return peak_bytes_; }
  int spills() const { return spills_; }
  int reloads() const { return reloads_; }

 private:
  struct Resident {
    TileAccumulator acc;
    int64_t last_touch = 0;
  };
  std::filesystem::path SpillPath(int tile) const;

  int tile_cells_, keep_;
  std::vector<int64_t> last_use_;
  std::filesystem::path spill_dir_;
  std::map<int, Resident> resident_;
  std::vector<char> spilled_;
  size_t bytes_ = 0, peak_bytes_ = 0;
  int spills_ = 0, reloads_ = 0;
};

}  // namespace rs
