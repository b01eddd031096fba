#pragma once
// The example trace the hostile cases start from (examples/, a simulated D150 F1000 circle).
#include <string>

namespace circtest::testing {

inline const std::string kExample =
    std::string(CIRCTEST_SOURCE_DIR) + "/examples/sim-d150-f1000.csv";

}  // namespace circtest::testing
