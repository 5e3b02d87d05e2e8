#pragma once
// Error tiers (as in COLMAP):
//  - InputError: something a user gave us is wrong (a file, a field, an option). Thrown at the
//    boundary, caught once in main, printed as one line, exit code 2.
//  - std::logic_error / TORCH_CHECK: API misuse inside the program (a bug). Exit code 3.
//  - Expected algorithmic failure (registration did not converge, too few matches) is a return
//    value (a result struct with a flag), never an exception.
#include <stdexcept>
#include <string>

namespace nerfreg {

class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& message) : std::runtime_error(message) {}
};

// "FILE: FIELD: expected EXPECTED" — the one-line message format every parser uses, so scripts
// and the bad-input battery can match on it. `field` may be empty when the whole file is bad.
std::string FormatInputError(const std::string& file, const std::string& field, const std::string& expected);

[[noreturn]] void ThrowInputError(const std::string& file, const std::string& field, const std::string& expected);

}  // namespace nerfreg

// Checks a condition about user input; on failure throws InputError(FILE: FIELD: expected ...).
#define NERFREG_CHECK_INPUT(cond, file, field, expected)            \
  do {                                                              \
    if (!(cond)) ::nerfreg::ThrowInputError(file, field, expected); \
  } while (0)
