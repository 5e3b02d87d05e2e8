#pragma once
// Helpers for tests: a fresh temporary directory per test, removed afterwards.
#include <functional>
#include <string>

namespace nerfreg {

class ScopedTempDir {
 public:
  ScopedTempDir();
  ~ScopedTempDir();
  const std::string& path() const { return path_; }
  std::string File(const std::string& name) const { return path_ + "/" + name; }

 private:
  std::string path_;
};

// Runs f and returns the message of the InputError it throws, or "" when it throws none.
std::string InputErrorOf(const std::function<void()>& f);

}  // namespace nerfreg
