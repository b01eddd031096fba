#pragma once
// The certified reference data (TraCIM, ...) lives beside the checkout (../shared/reference,
// CMake cache CIRCTEST_REFERENCE_DIR), not in the repository: a checkout without it skips
// those tests with a message instead of failing them.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

namespace circtest::testing {

// A file or folder of the reference data, by its path inside the reference folder.
inline std::string reference_path(const std::string& relative) {
  return std::string(CIRCTEST_REFERENCE_DIR) + "/" + relative;
}

}  // namespace circtest::testing

// Skips the current test when `path` (from reference_path) is absent.
#define CIRCTEST_SKIP_WITHOUT_REFERENCE(path)                                         \
  do {                                                                                \
    if (!std::filesystem::exists(path)) {                                             \
      GTEST_SKIP() << "reference data not found: " << (path)                          \
                   << " (set CIRCTEST_REFERENCE_DIR to the shared reference folder)"; \
    }                                                                                 \
  } while (false)
