#include "nerfreg/util/error.h"

namespace nerfreg {

std::string FormatInputError(const std::string& file, const std::string& field, const std::string& expected) {
  std::string msg = file;
  if (!field.empty()) msg += ": " + field;
  msg += ": expected " + expected;
  return msg;
}

void ThrowInputError(const std::string& file, const std::string& field, const std::string& expected) {
  throw InputError(FormatInputError(file, field, expected));
}

}  // namespace nerfreg
