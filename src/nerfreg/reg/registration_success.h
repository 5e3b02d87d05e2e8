#pragma once
// The success test of a registration against its truth, as DReg-NeRF scores it: within 5 degrees
// and 5 % of the object extent. Objects are normalised to a largest side of kObjectExtent by
// `nerfreg render` and `reg make-data` (render/mesh.h, render/procedural.h), so translation errors
// are reported as fractions of it.
namespace nerfreg {

inline constexpr double kObjectExtent = 2.5;

// translation: the full norm of the translation error, scene units.
inline bool RegistrationSucceeded(double rotation_deg, double translation, double max_rotation_deg = 5.0,
                                  double max_translation_fraction = 0.05) {
  return rotation_deg <= max_rotation_deg && translation / kObjectExtent <= max_translation_fraction;
}

}  // namespace nerfreg
