// Compares two directories of circana outputs written by bench/results-unchanged.sh (before
// and after a change): every file present in both, exit codes and error text identical, JSON
// of the same shape with every string identical and every number within the tolerance.
// Prints the largest numeric difference and where; exit 0 if all agree, 1 if not.
// usage: compare_results BEFORE_DIR AFTER_DIR [TOLERANCE, default 1e-9]
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>
#include "scratch.hpp"

namespace {

namespace fs = std::filesystem;
using nlohmann::ordered_json;

struct Outcome {
  double largest = 0.0;
  std::string where;
  int mismatches = 0;
};

// A file that is not there reads as "" (the checks below then say what is missing).
std::string slurp(const fs::path& p) {
  return circtest::testing::slurp_if_exists(p);
}

void differ(Outcome& o, const std::string& where, const std::string& what) {
  if (++o.mismatches <= 20) std::printf("DIFFERENT %s: %s\n", where.c_str(), what.c_str());
}

void compare(const ordered_json& a, const ordered_json& b, const std::string& where, double tol,
             Outcome& o) {
  if (a.is_number() && b.is_number()) {
    const double x = a.get<double>();
    const double y = b.get<double>();
    const double d = std::abs(x - y);
    if (!(d <= tol) && !(x == y)) differ(o, where, a.dump() + " vs " + b.dump());
    if (d > o.largest) {
      o.largest = d;
      o.where = where;
    }
    return;
  }
  if (a.type() != b.type()) {
    differ(o, where, "type " + std::string(a.type_name()) + " vs " + b.type_name());
    return;
  }
  if (a.is_object()) {
    if (a.size() != b.size()) differ(o, where, "different keys");
    for (auto it = a.begin(); it != a.end(); ++it) {
      if (!b.contains(it.key())) {
        differ(o, where + "." + it.key(), "missing after");
        continue;
      }
      compare(it.value(), b.at(it.key()), where + "." + it.key(), tol, o);
    }
    return;
  }
  if (a.is_array()) {
    if (a.size() != b.size()) {
      differ(o, where, "array sizes differ");
      return;
    }
    for (std::size_t i = 0; i < a.size(); ++i) {
      compare(a[i], b[i], where + "[" + std::to_string(i) + "]", tol, o);
    }
    return;
  }
  if (a != b) differ(o, where, a.dump() + " vs " + b.dump());
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: compare_results BEFORE_DIR AFTER_DIR [TOLERANCE]\n");
    return 2;
  }
  const fs::path before = argv[1];
  const fs::path after = argv[2];
  const double tol = argc > 3 ? std::strtod(argv[3], nullptr) : 1e-9;
  Outcome o;
  int files = 0;
  for (const auto& entry : fs::directory_iterator(before)) {
    const fs::path name = entry.path().filename();
    const fs::path other = after / name;
    ++files;
    if (!fs::exists(other)) {
      differ(o, name.string(), "missing after");
      continue;
    }
    const std::string a = slurp(entry.path());
    const std::string b = slurp(other);
    if (name.extension() != ".json" || a.empty() || b.empty()) {
      if (a != b) differ(o, name.string(), "text differs");
      continue;
    }
    try {
      compare(ordered_json::parse(a), ordered_json::parse(b), name.string(), tol, o);
    } catch (const nlohmann::json::exception& e) {
      differ(o, name.string(), e.what());
    }
  }
  std::printf("%d files compared, %d differences beyond %g; largest numeric difference %g%s%s\n",
              files, o.mismatches, tol, o.largest, o.where.empty() ? "" : " at ", o.where.c_str());
  return o.mismatches == 0 && files > 0 ? 0 : 1;
}
