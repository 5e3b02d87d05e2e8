#pragma once
// `reg register`'s job beside the registration itself (RegisterBlocks,
// registration/register_blocks.h): the pictures of its result.
#include <string>

#include "nerfreg/registration/register_blocks.h"

namespace nerfreg {

// Before / after pictures of a registration beside `out` (OUT_before.png, OUT_after.png): the
// chosen candidate's source points in orange, target in blue, from three fixed viewpoints.
void WriteRegistrationOverlays(const std::string& out, const BlockRegistrationResult& result);

// What `reg register` prints for a person (the full record is T.json, `--json` prints it):
//   registered  dreg+icp+block+field (auto, scale free), 12.3 s
//   rotation    123.45 deg about (0.123, -0.456, 0.789)
//   translation (0.1234, -0.5678, 0.9012), |t| 1.0912 (target units)
//   scale       0.9981
//   confidence  0.77, 2 of 2 other candidates agree ("one candidate only" with one)
//   written     T.json, T_before.png, T_after.png
// and, when untrusted, "untrusted   REASON" in place of the first word.
std::string RegistrationSummary(const BlockRegistrationResult& result, const std::string& out);

}  // namespace nerfreg
