#pragma once
// The training logs (OUT.log.jsonl, one JSON object a line) of nerf train, reg train and dbarf
// pretrain / finetune, kept in step with the training state they describe.
#include <cstdint>
#include <string>

namespace nerfreg {

// Before a resumed run appends to the log at `path`: keeps only the complete lines whose "step" is
// at most `step` (the state's). A run killed between checkpoints has logged steps that the resumed
// run repeats, and may have left half a line; without this the log would hold both and the broken
// line. Rewritten atomically; lines without a "step" are kept; a missing file is left missing.
// Returns the number of lines dropped.
int RewindTrainingLog(const std::string& path, std::int64_t step);

}  // namespace nerfreg
