#pragma once
// Helpers for tests: a fresh temporary directory per test, removed afterwards.
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

}  // namespace nerfreg
