#pragma once
// The registration flags reg register and reg register-many share (exe/reg_commands.cc): one pair's
// options, as typed; the enums are parsed after CLI11 has checked the names.
#include <string>

#include "nerfreg/registration/registration_options.h"

namespace CLI {
class App;
}  // namespace CLI

namespace nerfreg {

struct PairRegistrationFlags {
  std::string method, refine = "field", dreg_solver = "procrustes", icp_points = "occupied", scale = "free";
  bool no_flips = false, no_block_icp = false, no_turn_check = false, no_reverse = false;
  std::string device = "cpu";
  BlockRegistrationOptions options;
};

// --method, --scale, --refine, ... --no-turn-check, --device, with reg register's defaults.
void AddPairRegistrationFlags(CLI::App& app, PairRegistrationFlags* f);
// The options the flags say, checked (InputError naming the flag).
BlockRegistrationOptions ParsePairRegistrationFlags(const PairRegistrationFlags& f);

}  // namespace nerfreg
