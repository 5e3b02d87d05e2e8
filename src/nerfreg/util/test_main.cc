// Shared GoogleTest main: logging set to warnings so test output stays readable.
#include <gtest/gtest.h>

#include "nerfreg/util/logging.h"

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  nerfreg::LogOptions log;
  log.quiet = true;
  nerfreg::InitLogging(log);
  return RUN_ALL_TESTS();
}
