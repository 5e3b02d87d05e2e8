#pragma once
// `reg register`'s job beside the registration itself (RegisterBlocks,
// registration/register_blocks.h): the pictures of its result.
#include <string>

#include "nerfreg/registration/register_blocks.h"

namespace nerfreg {

// Before / after pictures of a registration beside `out` (OUT_before.png, OUT_after.png): the
// chosen candidate's source points in orange, target in blue, from three fixed viewpoints.
void WriteRegistrationOverlays(const std::string& out, const BlockRegistrationResult& result);

}  // namespace nerfreg
