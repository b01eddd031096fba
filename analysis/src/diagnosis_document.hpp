#pragma once
// The head every diagnosis document starts with, a plane's and a test set's alike: units,
// schema, version, the plane (or the planes' list), the axes and the feeds.
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "circtest/core/diagnosis_keys.hpp"

namespace circtest::detail {

inline nlohmann::ordered_json diagnosis_document_head(const std::string& plane,
                                                      const std::vector<char>& axes,
                                                      const std::vector<double>& feeds_mm_per_min) {
  namespace K = diagnosis_json::key;
  nlohmann::ordered_json j;
  j[K::units] = "mm";
  j[K::schema] = diagnosis_json::kSchema;
  j[K::version] = diagnosis_json::kVersion;
  j[K::plane] = plane;
  nlohmann::ordered_json names = nlohmann::ordered_json::array();
  for (const char a : axes) names.push_back(std::string(1, a));
  j[K::axes] = names;
  j[K::feeds_mm_per_min] = feeds_mm_per_min;
  return j;
}

}  // namespace circtest::detail
