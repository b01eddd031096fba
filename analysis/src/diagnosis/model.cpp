// The diagnosis model's shared helpers that need no inlining.
#include "model.hpp"

#include "circtest/core/diagnosis_keys.hpp"

namespace circtest::diagnosis_detail {

unsigned diagnosis_threads() {
  static const unsigned threads = thread_count(ThreadCountRequest{.max_threads = 8});
  return threads;
}

std::string kind_name(Kind k, const std::array<char, 2>& axes) {
  const std::string A(1, axes[0]), B(1, axes[1]);
  switch (k) {
    case Kind::centre_a:
      return "centre offset " + A;
    case Kind::centre_b:
      return "centre offset " + B;
    case Kind::radius:
      return "radius change";
    case Kind::scale_mismatch:
      return "scale mismatch";
    case Kind::squareness:
      return "squareness";
    case Kind::servo:
      return "servo mismatch";
    case Kind::backlash_a:
      return "backlash " + A;
    case Kind::backlash_b:
      return "backlash " + B;
    case Kind::spike_a:
      return "reversal spike " + A;
    case Kind::spike_b:
      return "reversal spike " + B;
    case Kind::cyclic_a_sin:
    case Kind::cyclic_a_cos:
      return "cyclic " + A;
    case Kind::cyclic_b_sin:
    case Kind::cyclic_b_cos:
      return "cyclic " + B;
    case Kind::spike_tau_a:
    case Kind::spike_tau_b:
      return "spike decay";
  }
  return "?";
}

std::string term_key(Kind k, const std::array<char, 2>& axes) {
  namespace K = diagnosis_json::key;
  const auto axis = [&axes](const char* key, int ax) {
    return std::string(key) + "." + axes[static_cast<std::size_t>(ax)];
  };
  switch (k) {
    case Kind::scale_mismatch:
      return K::scale_mismatch_ppm;
    case Kind::squareness:
      return K::squareness_urad;
    case Kind::servo:
      return K::servo_mismatch_ms;
    case Kind::backlash_a:
      return axis(K::backlash_mm, 0);
    case Kind::backlash_b:
      return axis(K::backlash_mm, 1);
    case Kind::spike_a:
      return axis(K::reversal_spike_mm, 0);
    case Kind::spike_b:
      return axis(K::reversal_spike_mm, 1);
    case Kind::cyclic_a_sin:
    case Kind::cyclic_a_cos:
      return axis(K::cyclic, 0);
    case Kind::cyclic_b_sin:
    case Kind::cyclic_b_cos:
      return axis(K::cyclic, 1);
    case Kind::centre_a:
    case Kind::centre_b:
    case Kind::radius:
    case Kind::spike_tau_a:
    case Kind::spike_tau_b:
      return {};
  }
  return {};
}

std::optional<std::size_t> find(const std::vector<Column>& cols, Kind k, int group) {
  for (std::size_t j = 0; j < cols.size(); ++j) {
    if (cols[j].kind == k && (k != Kind::radius || cols[j].group == group)) return j;
  }
  return std::nullopt;
}

}  // namespace circtest::diagnosis_detail
