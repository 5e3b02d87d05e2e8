#include "nerfreg/registration/registration_options.h"

#include <cmath>

namespace nerfreg {

namespace {

const EnumNames<RegistrationMethod> kMethodNames{{{RegistrationMethod::kAuto, "auto"},
                                                  {RegistrationMethod::kDreg, "dreg"},
                                                  {RegistrationMethod::kRansac, "ransac"},
                                                  {RegistrationMethod::kFgr, "fgr"}}};
const EnumNames<RegistrationRefinement> kRefinementNames{{{RegistrationRefinement::kNone, "none"},
                                                          {RegistrationRefinement::kIcp, "icp"},
                                                          {RegistrationRefinement::kField, "field"}}};
const EnumNames<DregSolver> kSolverNames{{{DregSolver::kProcrustes, "procrustes"}, {DregSolver::kRansac, "ransac"}}};
const EnumNames<IcpPoints> kIcpPointsNames{{{IcpPoints::kOccupied, "occupied"}, {IcpPoints::kMask, "mask"}}};
const EnumNames<ScaleMode> kScaleModeNames{{{ScaleMode::kFree, "free"}, {ScaleMode::kFixed, "fixed"}}};

}  // namespace

std::string RegistrationMethodName(RegistrationMethod m) { return kMethodNames.Name(m); }
std::string RegistrationRefinementName(RegistrationRefinement r) { return kRefinementNames.Name(r); }
std::string DregSolverName(DregSolver s) { return kSolverNames.Name(s); }
std::string IcpPointsName(IcpPoints p) { return kIcpPointsNames.Name(p); }
std::string ScaleModeName(ScaleMode m) { return kScaleModeNames.Name(m); }
RegistrationMethod RegistrationMethodFromName(const std::string& name, const std::string& option) {
  return kMethodNames.FromName(name, option);
}
RegistrationRefinement RegistrationRefinementFromName(const std::string& name, const std::string& option) {
  return kRefinementNames.FromName(name, option);
}
DregSolver DregSolverFromName(const std::string& name, const std::string& option) {
  return kSolverNames.FromName(name, option);
}
IcpPoints IcpPointsFromName(const std::string& name, const std::string& option) {
  return kIcpPointsNames.FromName(name, option);
}
ScaleMode ScaleModeFromName(const std::string& name, const std::string& option) {
  return kScaleModeNames.FromName(name, option);
}

void BlockRegistrationOptions::Check() const {
  field.Check();
  grid.Check();
  // The network's 3D backbone halves the grid four times (reg/backbone.h).
  if (UsesNetwork() && grid.resolution % 16 != 0) {
    ThrowInputError("--grid-resolution", "",
                    "a multiple of 16 for the network (--method dreg or auto), got " + std::to_string(grid.resolution));
  }
  if (!(min_confidence >= 0 && min_confidence <= 1)) ThrowInputError("--min-confidence", "", "in [0, 1]");
  if (config != "" && config != "cpu" && config != "paper") ThrowInputError("--config", "", "cpu or paper");
  if (!(min_density >= 0)) ThrowInputError("--min-density", "", ">= 0");
  if (!(voxel > 0)) ThrowInputError("--voxel", "", "> 0");
  if (max_points < 0) ThrowInputError("--max-points", "", ">= 0");
  if (!(icp_distance > 0)) ThrowInputError("--icp-distance", "", "> 0 (ICP voxels)");
  if (dreg_passes < 1 || dreg_passes > 10) ThrowInputError("--dreg-passes", "", "1..10");
  splats.Check();
}

Json BlockRegistrationOptions::ToJson() const {
  return {{"method", RegistrationMethodName(method)},
          {"refine", RegistrationRefinementName(refine)},
          {"scale", ScaleModeName(scale)},
          {"min_confidence", min_confidence},
          {"field_iterations", field.iterations},
          {"field_occupancy_scale", field.occupancy_scale},
          {"field_samples", field.max_samples},
          {"grid_resolution", grid.resolution},
          {"weights", weights},
          {"config", config},
          {"min_density", min_density},
          {"voxel", voxel},
          {"max_points", max_points},
          {"icp_points", IcpPointsName(icp_points)},
          {"flips", flips},
          {"icp_distance", icp_distance},
          {"seed", seed},
          {"dreg_solver", DregSolverName(dreg_solver)},
          {"dreg_passes", dreg_passes},
          {"block_icp", block_icp},
          {"check_turns", check_turns},
          {"reverse_untrusted", reverse_untrusted},
          {"splat_density_scale", splats.density_scale},
          {"splat_blur", splats.blur}};
}

BlockRegistrationOptions BlockRegistrationOptions::FromJson(const Json& json, const std::string& file) {
  const JsonField j(json, file);
  BlockRegistrationOptions o;
  o.method = RegistrationMethodFromName(j["method"].String(), file + ": method");
  o.refine = RegistrationRefinementFromName(j["refine"].String(), file + ": refine");
  // Absent in T.json files written before Sim(3) registration, which was rigid.
  o.scale = ScaleModeFromName(j.StringOr("scale", "fixed"), file + ": scale");
  o.min_confidence = j["min_confidence"].Double();
  o.field.iterations = j["field_iterations"].Int();
  o.field.occupancy_scale = j["field_occupancy_scale"].Double();
  o.field.max_samples = j["field_samples"].Int();
  o.grid.resolution = j["grid_resolution"].Int();
  o.weights = j["weights"].String();
  o.config = j["config"].String();
  o.min_density = j["min_density"].Double();
  o.voxel = j["voxel"].Double();
  o.max_points = j["max_points"].Int();
  o.icp_points = IcpPointsFromName(j["icp_points"].String(), file + ": icp_points");
  o.flips = j["flips"].Bool();
  o.icp_distance = j["icp_distance"].Double();
  const double seed = j["seed"].Double();
  if (!(seed >= 0 && seed <= 4294967295.0 && seed == std::floor(seed))) j["seed"].Fail("an integer in [0, 2^32)");
  o.seed = static_cast<unsigned>(seed);
  o.dreg_solver = DregSolverFromName(j["dreg_solver"].String(), file + ": dreg_solver");
  o.dreg_passes = j["dreg_passes"].Int();
  o.block_icp = j["block_icp"].Bool();
  // Absent in T.json files written before the turn check.
  o.check_turns = j.BoolOr("check_turns", false);
  // Absent in T.json files written before an untrusted result was registered the other way.
  o.reverse_untrusted = j.BoolOr("reverse_untrusted", false);
  // Absent in T.json files written before splat inputs.
  o.splats.density_scale = j.DoubleOr("splat_density_scale", o.splats.density_scale);
  o.splats.blur = j.DoubleOr("splat_blur", o.splats.blur);
  return o;
}

}  // namespace nerfreg
