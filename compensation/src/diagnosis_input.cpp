// circcomp's view of the diagnosis document: read through the one reader
// (core/diagnosis_document.hpp), then each plane as the planner takes it.
#include "circtest/compensation/diagnosis_input.hpp"

#include <fmt/format.h>

#include <set>

#include "circtest/core/diagnosis_document.hpp"
#include "circtest/core/diagnosis_keys.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/input_file.hpp"

namespace circtest::compensation {

namespace {

// A test set: each plane's own diagnosis with the per-axis values the set joined; an axis an
// earlier plane carries has its per-axis values cleared in the later ones, so that each axis
// is corrected once.
std::vector<DiagnosisInput> set_inputs(const DiagnosisDocument& doc, const std::string& source) {
  std::vector<DiagnosisInput> out;
  std::set<char> carried;
  for (const Diagnosis& d : doc.planes) {
    DiagnosisInput in{source, d, {false, false}};
    Diagnosis& p = in.diagnosis;
    for (std::size_t k = 0; k < 2; ++k) {
      if (!carried.insert(d.axes[k]).second) {
        in.axis_in_earlier_plane[k] = true;
        p.backlash_mm[k] = {};
        p.spike_mm[k] = {};
        p.spike_ms[k] = {};
        p.scale_ppm[k] = {};
        p.cyclic[k] = std::nullopt;
        continue;
      }
      const JointAxisValues& j = doc.joint.at(d.axes[k]);
      p.backlash_mm[k] = j.backlash_mm;
      p.spike_mm[k] = j.spike_mm;
      p.spike_ms[k] = j.spike_ms;
      p.scale_ppm[k] = j.scale_ppm;
    }
    // The plane's squareness from the set's joint fit where the document has a value.
    if (const auto it = doc.joint_squareness_urad.find(d.plane);
        it != doc.joint_squareness_urad.end() && it->second.value) {
      p.squareness_urad = it->second;
    }
    p.ini_sha256 = doc.ini_sha256;
    out.push_back(std::move(in));
  }
  return out;
}

}  // namespace

DiagnosisInput parse_diagnosis(const std::string& text, const std::string& source) {
  std::vector<DiagnosisInput> planes = parse_diagnosis_planes(text, source);
  if (planes.size() > 1) {
    throw ParseError(source, 0,
                     fmt::format("\"{}\": a test set ({} planes): read it plane by plane",
                                 diagnosis_json::key::plane, planes.size()));
  }
  return std::move(planes.front());
}

std::vector<DiagnosisInput> parse_diagnosis_planes(const std::string& text,
                                                   const std::string& source) {
  const DiagnosisDocument doc = parse_diagnosis_document(text, source, "circcomp");
  if (doc.test_set) return set_inputs(doc, source);
  return {DiagnosisInput{source, doc.planes.front(), {false, false}}};
}

DiagnosisInput read_diagnosis(const std::string& path) {
  return parse_diagnosis(read_input_text(path, kMaxDiagnosisBytes), path);
}

std::vector<DiagnosisInput> read_diagnosis_planes(const std::string& path) {
  return parse_diagnosis_planes(read_input_text(path, kMaxDiagnosisBytes), path);
}

}  // namespace circtest::compensation
