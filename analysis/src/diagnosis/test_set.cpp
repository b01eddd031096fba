// A test set split into its planes, and the planes' diagnoses joined (test_set.hpp).
#include "circtest/analysis/test_set.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <map>

#include "circtest/core/diagnosis_document.hpp"
#include "circtest/core/diagnosis_keys.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/json_text.hpp"
#include "circtest/core/numbers.hpp"
#include "circtest/core/strings.hpp"
#include "circtest/core/trace_keys.hpp"

namespace circtest {

namespace {

using json = nlohmann::ordered_json;
namespace K = diagnosis_json::key;

struct SetSegment {
  long id = 0;
  std::size_t plane = 0;  // index into the set's planes
  std::string text;       // "id:DIR:Ffeed", the entry without its plane
};

std::vector<std::string_view> split_items(std::string_view text, char sep) {
  std::vector<std::string_view> out;
  std::size_t pos = 0;
  while (pos <= text.size()) {
    const std::size_t end = std::min(text.find(sep, pos), text.size());
    std::string_view item = trim(text.substr(pos, end - pos));
    if (!item.empty() || sep == ':') out.push_back(item);
    pos = end + 1;
  }
  return out;
}

// The `segments` entries with their planes.
std::vector<SetSegment> set_segments(const Trace& trace, const std::vector<Plane>& planes) {
  const std::string* text = trace.metadata.find(meta_key::segments);
  const std::size_t line = trace.metadata.line_of(meta_key::segments);
  if (!text) {
    throw DataError(trace.source, trace.metadata.line_of(meta_key::plane),
                    "a test set (metadata 'plane' lists several planes) without 'segments' "
                    "metadata: which run belongs to which plane is not known (circgen's set "
                    "program writes it)");
  }
  std::vector<SetSegment> out;
  for (std::string_view item : split_items(*text, ',')) {
    const std::vector<std::string_view> f = split_items(item, ':');
    const auto id = parse_finite(f[0]);
    const std::string shown = printable_ascii(item.substr(0, 40));
    if (!id || *id < 1 || *id > 2147483647.0 || std::floor(*id) != *id) {
      throw ParseError(trace.source, line,
                       fmt::format("metadata 'segments': entry '{}': expected id:DIR:Ffeed:PLANE "
                                   "with a run id 1..2147483647",
                                   shown));
    }
    if (f.size() < 4) {
      throw ParseError(trace.source, line,
                       fmt::format("metadata 'segments': entry '{}' names no plane: a test set's "
                                   "entries are id:DIR:Ffeed:PLANE",
                                   shown));
    }
    const std::optional<Plane> p = parse_plane(f[3]);
    const auto at = p ? std::find(planes.begin(), planes.end(), *p) : planes.end();
    if (at == planes.end()) {
      throw ParseError(trace.source, line,
                       fmt::format("metadata 'segments': entry '{}': plane '{}' is not one of the "
                                   "set's planes ({}, metadata 'plane' line {})",
                                   shown, printable_ascii(f[3].substr(0, 10)),
                                   *trace.metadata.find(meta_key::plane),
                                   trace.metadata.line_of(meta_key::plane)));
    }
    const long lid = static_cast<long>(*id);
    if (std::any_of(out.begin(), out.end(), [&](const SetSegment& s) { return s.id == lid; })) {
      throw ParseError(trace.source, line,
                       fmt::format("metadata 'segments': run id {} is given twice", lid));
    }
    out.push_back({lid, static_cast<std::size_t>(at - planes.begin()),
                   fmt::format("{}:{}:{}", f[0], f[1], f[2])});
  }
  return out;
}

// The first and one past the last row of each plane's runs; npos for a plane without any.
std::vector<std::array<std::size_t, 2>> plane_rows(const Trace& trace,
                                                   const std::vector<Plane>& planes,
                                                   const std::vector<SetSegment>& segments) {
  const std::vector<double>* seg = trace.column(column_name::segment);
  if (!seg) {
    throw DataError(trace.source, trace.header_line,
                    "a test set without a 'segment' column: the runs cannot be told apart by "
                    "plane (record the set with circlog-record and the program's segment output)");
  }
  std::map<long, std::size_t> plane_of;
  for (const SetSegment& s : segments) plane_of[s.id] = s.plane;
  std::vector<std::array<std::size_t, 2>> rows(planes.size(),
                                               {std::string::npos, std::string::npos});
  std::optional<std::size_t> current;
  for (std::size_t r = 0; r < trace.rows(); ++r) {
    const double v = (*seg)[r];
    if (v == 0.0 || !std::isfinite(v)) continue;
    const long id = std::lround(v);
    const auto it = plane_of.find(id);
    if (it == plane_of.end()) {
      throw DataError(trace.source, trace.line_of_row[r],
                      fmt::format("segment {}: a run the metadata 'segments' (line {}) does not "
                                  "announce, so its plane is not known",
                                  id, trace.metadata.line_of(meta_key::segments)));
    }
    const std::size_t p = it->second;
    if (current && p != *current && rows[p][0] != std::string::npos) {
      throw DataError(trace.source, trace.line_of_row[r],
                      fmt::format("segment {} ({}) comes after runs of {}: a set's planes run one "
                                  "after another, each once",
                                  id, plane_name(planes[p]), plane_name(planes[*current])));
    }
    if (rows[p][0] == std::string::npos) rows[p][0] = r;
    rows[p][1] = r + 1;
    current = p;
  }
  for (std::size_t p = 0; p < planes.size(); ++p) {
    if (rows[p][0] == std::string::npos) {
      throw DataError(trace.source, trace.metadata.line_of(meta_key::plane),
                      fmt::format("plane {} of the set has no run in the trace (the recording "
                                  "stopped early?)",
                                  plane_name(planes[p])));
    }
  }
  return rows;
}

// The plane's metadata: the set's, with `plane` and `segments` its own and the set's
// direction labels (which name each plane's axes) left out.
TraceMetadata plane_metadata(const Trace& trace, Plane plane, std::size_t index,
                             const std::vector<SetSegment>& segments) {
  TraceMetadata m;
  const auto& entries = trace.metadata.entries();
  for (std::size_t i = 0; i < entries.size(); ++i) {
    const std::string& key = entries[i].first;
    if (key == meta_key::plane || key == meta_key::segments || key == meta_key::direction_labels)
      continue;
    m.set(key, entries[i].second);
    m.set_line(m.entries().size() - 1, trace.metadata.line_at(i));
  }
  m.set(meta_key::plane, std::string(plane_name(plane)));
  m.set_line(m.entries().size() - 1, trace.metadata.line_of(meta_key::plane));
  std::string own;
  for (const SetSegment& s : segments) {
    if (s.plane == index) own += (own.empty() ? "" : ",") + s.text;
  }
  m.set(meta_key::segments, own);
  m.set_line(m.entries().size() - 1, trace.metadata.line_of(meta_key::segments));
  return m;
}

}  // namespace

std::size_t plane_index(Plane plane) noexcept {
  return plane == Plane::XY ? 0 : (plane == Plane::YZ ? 1 : 2);
}

namespace {

// A single-plane trace's `segments` entries that name a plane (circgen writes it for every
// program) must name the trace's: a trace whose two plane records disagree is refused.
void check_segment_planes(const Trace& trace, Plane plane) {
  const std::string* segments = trace.metadata.find(meta_key::segments);
  if (!segments) return;
  for (std::string_view item : split_items(*segments, ',')) {
    const std::vector<std::string_view> f = split_items(item, ':');
    if (f.size() < 4) continue;
    const std::optional<Plane> p = parse_plane(f[3]);
    if (p == plane) continue;
    throw ParseError(
        trace.source, trace.metadata.line_of(meta_key::segments),
        fmt::format("metadata 'segments': entry '{}' names the plane '{}', the trace's plane is "
                    "{} (metadata 'plane' line {})",
                    printable_ascii(item.substr(0, 40)), printable_ascii(f[3].substr(0, 10)),
                    plane_name(plane), trace.metadata.line_of(meta_key::plane)));
  }
}

}  // namespace

std::optional<std::vector<Plane>> test_set_planes(const Trace& trace) {
  const std::string* text = trace.metadata.find(meta_key::plane);
  if (!text) return std::nullopt;
  if (const std::optional<Plane> single = parse_plane(*text)) {
    check_segment_planes(trace, *single);
    return std::nullopt;
  }
  std::optional<std::vector<Plane>> planes = parse_plane_list(*text);
  if (!planes) {
    throw ParseError(trace.source, trace.metadata.line_of(meta_key::plane),
                     fmt::format("metadata 'plane': expected XY, YZ or ZX, or a test set's "
                                 "planes each once (XY,YZ,ZX), got '{}'",
                                 printable_ascii(std::string_view(*text).substr(0, 40))));
  }
  if (planes->size() < 2) {
    check_segment_planes(trace, planes->front());
    return std::nullopt;
  }
  return planes;
}

std::vector<PlaneTrace> split_test_set(const Trace& trace, const std::vector<Plane>& planes) {
  const std::vector<SetSegment> segments = set_segments(trace, planes);
  const auto rows = plane_rows(trace, planes, segments);
  // Program order: the planes as their runs come in the trace.
  std::vector<std::size_t> order(planes.size());
  for (std::size_t p = 0; p < planes.size(); ++p) order[p] = p;
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return rows[a][0] < rows[b][0]; });
  std::vector<PlaneTrace> out;
  for (std::size_t k = 0; k < order.size(); ++k) {
    const std::size_t p = order[k];
    const std::size_t begin = k == 0 ? 0 : rows[order[k - 1]][1];
    const std::size_t end = k + 1 == order.size() ? trace.rows() : rows[p][1];
    PlaneTrace pt;
    pt.plane = planes[p];
    Trace& t = pt.trace;
    t.source = trace.source;
    t.metadata = plane_metadata(trace, planes[p], p, segments);
    t.columns = trace.columns;
    t.header_line = trace.header_line;
    t.values.reserve(trace.values.size());
    const auto b = static_cast<std::ptrdiff_t>(begin), e = static_cast<std::ptrdiff_t>(end);
    for (const std::vector<double>& col : trace.values) {
      t.values.emplace_back(col.begin() + b, col.begin() + e);
    }
    t.line_of_row.assign(trace.line_of_row.begin() + b, trace.line_of_row.begin() + e);
    out.push_back(std::move(pt));
  }
  return out;
}

namespace {

// The 99.9 % point of chi-square with DOF degrees of freedom (Wilson-Hilferty; 10.9 for one).
double chi2_999(int dof) {
  const double k = dof;
  const double z = 3.090232;
  const double a = 1.0 - 2.0 / (9.0 * k) + z * std::sqrt(2.0 / (9.0 * k));
  return k * a * a * a;
}

void join_planes(JointEstimate& j) {
  std::vector<const PlaneEstimate*> have;
  for (const PlaneEstimate& p : j.planes) {
    if (p.estimate.value) have.push_back(&p);
  }
  if (have.empty()) return;
  const bool weighted = std::all_of(have.begin(), have.end(), [](const PlaneEstimate* p) {
    return p->estimate.standard_error && *p->estimate.standard_error > 0;
  });
  if (!weighted) {
    // A plane without a standard error cannot be weighted: the plain mean, with none. Planes
    // more than 10 % of it apart disagree (nothing says how far apart they may be).
    double sum = 0, lo = *have.front()->estimate.value, hi = lo;
    for (const PlaneEstimate* p : have) {
      sum += *p->estimate.value;
      lo = std::min(lo, *p->estimate.value);
      hi = std::max(hi, *p->estimate.value);
    }
    j.joint.value = sum / static_cast<double>(have.size());
    j.dof = static_cast<int>(have.size()) - 1;
    j.consistent = !(hi - lo > 0.1 * std::abs(*j.joint.value));
    return;
  }
  double sw = 0, swx = 0;
  for (const PlaneEstimate* p : have) {
    const double w = 1.0 / (*p->estimate.standard_error * *p->estimate.standard_error);
    sw += w;
    swx += w * *p->estimate.value;
  }
  const double mean = swx / sw;
  j.joint.value = mean;
  j.joint.standard_error = 1.0 / std::sqrt(sw);
  j.dof = static_cast<int>(have.size()) - 1;
  if (j.dof < 1) return;
  double chi2 = 0;
  for (const PlaneEstimate* p : have) {
    const double d = (*p->estimate.value - mean) / *p->estimate.standard_error;
    chi2 += d * d;
  }
  j.chi2 = chi2;
  j.consistent = chi2 <= chi2_999(j.dof);
  if (!j.consistent) *j.joint.standard_error *= std::sqrt(chi2 / j.dof);
}

void add(JointEstimate& j, Plane plane, const Estimate& e) {
  if (e.value) j.planes.push_back({plane, e});
}

std::string disagreement(const AxisJoint& a, const JointEstimate& j, const char* what,
                         const char* unit, double factor) {
  std::string s =
      j.chi2 ? fmt::format(
                   "the planes disagree on {} {} beyond their standard errors (chi2 "
                   "{:.1f} on {} dof):",
                   a.axis, what, *j.chi2, j.dof)
             : fmt::format("the planes disagree on {} {} by more than 10 % (no standard errors):",
                           a.axis, what);
  for (const PlaneEstimate& p : j.planes) {
    s += p.estimate.standard_error
             ? fmt::format(" {} {:.3f} {} (+- {:.3f})", plane_name(p.plane),
                           *p.estimate.value * factor, unit, *p.estimate.standard_error * factor)
             : fmt::format(" {} {:.3f} {}", plane_name(p.plane), *p.estimate.value * factor, unit);
  }
  if (!j.chi2) return s + "; the joint value is their plain mean";
  return s + fmt::format("; the joint value's standard error is widened by {:.1f}",
                         std::sqrt(*j.chi2 / j.dof));
}

}  // namespace

std::optional<std::string> take_joint_value(const AxisJoint& axis, JointEstimate& j,
                                            const Estimate& value, const char* what,
                                            const char* unit, double factor) {
  if (!value.value) return std::nullopt;
  j.joint = value;
  const double v = *value.value;
  std::size_t weighted = 0;
  double chi2 = 0, lo = v, hi = v;
  bool any = false;
  for (const PlaneEstimate& p : j.planes) {
    if (!p.estimate.value) continue;
    lo = any ? std::min(lo, *p.estimate.value) : *p.estimate.value;
    hi = any ? std::max(hi, *p.estimate.value) : *p.estimate.value;
    any = true;
    if (!p.estimate.standard_error || !(*p.estimate.standard_error > 0)) continue;
    const double d = (*p.estimate.value - v) / *p.estimate.standard_error;
    chi2 += d * d;
    ++weighted;
  }
  if (!any) return std::nullopt;
  if (weighted > 0) {
    j.chi2 = chi2;
    j.dof = static_cast<int>(weighted);
    j.consistent = chi2 <= chi2_999(j.dof);
    if (!j.consistent && j.joint.standard_error) *j.joint.standard_error *= std::sqrt(chi2 / j.dof);
  } else {
    const double margin = 0.1 * std::abs(v);
    j.consistent = v >= lo - margin && v <= hi + margin;
  }
  if (j.consistent) return std::nullopt;
  std::string s = fmt::format("the joint {} {} {:.3f} {} is not what the planes found:", axis.axis,
                              what, v * factor, unit);
  for (const PlaneEstimate& p : j.planes) {
    if (!p.estimate.value) continue;
    s += p.estimate.standard_error
             ? fmt::format(" {} {:.3f} {} (+- {:.3f})", plane_name(p.plane),
                           *p.estimate.value * factor, unit, *p.estimate.standard_error * factor)
             : fmt::format(" {} {:.3f} {}", plane_name(p.plane), *p.estimate.value * factor, unit);
  }
  if (!j.chi2) return s + " (more than 10 % outside their range)";
  return s + fmt::format(" (chi2 {:.1f} on {} dof); its standard error is widened by {:.1f}",
                         *j.chi2, j.dof, std::sqrt(*j.chi2 / j.dof));
}

SetDiagnosis join_set_diagnoses(std::string source, std::vector<Diagnosis> planes) {
  SetDiagnosis s;
  s.source = std::move(source);
  for (const char axis : {'X', 'Y', 'Z'}) {
    AxisJoint a;
    a.axis = axis;
    bool covered = false;
    for (const Diagnosis& d : planes) {
      for (std::size_t k = 0; k < 2; ++k) {
        if (d.axes[k] != axis) continue;
        covered = true;
        add(a.backlash_mm, d.plane, d.backlash_mm[k]);
        add(a.spike_mm, d.plane, d.spike_mm[k]);
        add(a.spike_ms, d.plane, d.spike_ms[k]);
        add(a.scale_ppm, d.plane, d.scale_ppm[k]);
        // The plane's own lag of the axis, in the convention the plane reports it (and the
        // joint fit's): following error over velocity as the trace logs it.
        add(a.lag_ms, d.plane, d.axis_lag[k].lag_ms);
      }
    }
    if (!covered) continue;
    const std::pair<JointEstimate*, std::array<const char*, 2>> params[] = {
        {&a.backlash_mm, {"backlash", "um"}},
        {&a.spike_mm, {"reversal spike", "um"}},
        {&a.spike_ms, {"reversal spike decay", "ms"}},
        {&a.scale_ppm, {"scale", "ppm"}},
        {&a.lag_ms, {"following lag", "ms"}}};
    for (const auto& [j, words] : params) {
      join_planes(*j);
      if (!j->consistent) {
        const double factor = std::string_view(words[1]) == "um" ? 1e3 : 1.0;
        s.notes.push_back(disagreement(a, *j, words[0], words[1], factor));
      }
    }
    s.axes.push_back(std::move(a));
  }
  for (const Diagnosis& d : planes) {
    s.planes.push_back(d.plane);
    s.squareness_urad[plane_index(d.plane)] = d.squareness_urad;
    for (double f : d.feeds_mm_per_min) {
      if (std::none_of(s.feeds_mm_per_min.begin(), s.feeds_mm_per_min.end(),
                       [&](double g) { return std::abs(g - f) <= 0.02 * f; })) {
        s.feeds_mm_per_min.push_back(f);
      }
    }
  }
  if (std::all_of(s.axes.begin(), s.axes.end(),
                  [](const AxisJoint& a) { return !a.scale_ppm.joint.value; })) {
    s.notes.push_back(
        "per-axis scale not available (no absolute length along the axes, or no nominal "
        "radius): each plane's scale mismatch is in its own diagnosis");
  }
  s.plane_diagnoses = std::move(planes);
  return s;
}

SetDiagnosis diagnose_set(const std::vector<PlaneTrace>& planes,
                          const std::vector<Evaluation>& evaluations,
                          const DiagnosisOptions& options) {
  std::vector<SetPlaneInput> in;
  for (std::size_t k = 0; k < planes.size(); ++k)
    in.push_back({&planes[k].trace, &evaluations[k], options});
  return diagnose_set(planes.empty() ? std::string() : planes.front().trace.source, in);
}

namespace {

std::string plane_list(const std::vector<Plane>& planes) {
  std::string s;
  for (Plane p : planes) {
    if (!s.empty()) s += ',';
    s += plane_name(p);
  }
  return s;
}

json agreement_json(const JointEstimate& j) {
  json o = json::object();
  for (const PlaneEstimate& p : j.planes) {
    o[std::string(plane_name(p.plane))] = {
        {K::value, json_number_or_null(p.estimate.value)},
        {K::standard_error, json_number_or_null(p.estimate.standard_error)}};
  }
  o[K::chi2] = json_number_or_null(j.chi2);
  o[K::dof] = j.dof;
  o[K::consistent] = j.consistent;
  return o;
}

using Member = JointEstimate AxisJoint::*;
constexpr std::pair<const char*, Member> kAxisKeys[] = {
    {K::backlash_mm, &AxisJoint::backlash_mm},
    {K::reversal_spike_mm, &AxisJoint::spike_mm},
    {K::reversal_spike_ms, &AxisJoint::spike_ms},
    {K::scale_ppm, &AxisJoint::scale_ppm},
    {K::axis_lag_ms, &AxisJoint::lag_ms}};

}  // namespace

json to_json(const SetDiagnosis& s) {
  std::vector<char> axes;
  for (const AxisJoint& a : s.axes) axes.push_back(a.axis);
  json j = diagnosis_document_head(plane_list(s.planes), axes, s.feeds_mm_per_min);
  json se = json::object();
  for (const auto& [key, member] : kAxisKeys) {
    json v = json::object(), e = json::object();
    for (const AxisJoint& a : s.axes) {
      v[std::string(1, a.axis)] = json_number_or_null((a.*member).joint.value);
      e[std::string(1, a.axis)] = json_number_or_null((a.*member).joint.standard_error);
    }
    j[key] = v;
    se[key] = e;
  }
  // One plane's number: a set has three, under test_set.
  j[K::squareness_urad] = nullptr;
  j[K::standard_error] = se;
  json set;
  json planes = json::array();
  for (Plane p : s.planes) planes.push_back(std::string(plane_name(p)));
  set[K::planes] = planes;
  set[K::method] = s.joint_fit ? "one model across the set" : "planes joined";
  json sq = json::object();
  for (Plane p : {Plane::XY, Plane::YZ, Plane::ZX}) {
    const auto& e = s.squareness_urad[plane_index(p)];
    if (e)
      sq[std::string(plane_name(p))] = {
          {K::value, json_number_or_null(e->value)},
          {K::standard_error, json_number_or_null(e->standard_error)}};
  }
  set[K::squareness_urad] = sq;
  json agreement = json::object();
  for (const auto& [key, member] : kAxisKeys) {
    json per = json::object();
    for (const AxisJoint& a : s.axes) per[std::string(1, a.axis)] = agreement_json(a.*member);
    agreement[key] = per;
  }
  set[K::agreement] = agreement;
  json diagnoses = json::array();
  for (const Diagnosis& d : s.plane_diagnoses) diagnoses.push_back(to_json(d));
  set[K::diagnoses] = diagnoses;
  j[K::test_set] = set;
  std::size_t runs = 0, samples = 0;
  for (const Diagnosis& d : s.plane_diagnoses) runs += d.runs, samples += d.samples;
  j[K::runs] = runs;
  j[K::samples] = samples;
  const auto sha = s.plane_diagnoses.empty() ? std::nullopt : s.plane_diagnoses.front().ini_sha256;
  j[K::ini_sha256] = sha ? json(*sha) : json(nullptr);
  j[K::source] = s.source;
  j[K::notes] = s.notes;
  return j;
}

namespace {

std::string estimate_text(const Estimate& e, double factor, const char* unit) {
  if (!e.value) return "not available";
  if (!e.standard_error) return fmt::format("{:+.2f} {}", *e.value * factor, unit);
  return fmt::format("{:+.2f} {} (+- {:.2f})", *e.value * factor, unit, *e.standard_error * factor);
}

void joint_line(std::string& s, const char* what, const JointEstimate& j, double factor,
                const char* unit) {
  auto out = std::back_inserter(s);
  fmt::format_to(out, "    {:<22} {}", what, estimate_text(j.joint, factor, unit));
  if (j.planes.size() > 1 || (j.planes.size() == 1 && j.joint.value)) {
    s += "  [";
    for (std::size_t k = 0; k < j.planes.size(); ++k) {
      fmt::format_to(out, "{}{} {}", k ? ", " : "", plane_name(j.planes[k].plane),
                     estimate_text(j.planes[k].estimate, factor, unit));
    }
    s += "]";
    if (j.chi2 || !j.consistent) s += j.consistent ? " agree" : " DISAGREE";
  }
  s += '\n';
}

}  // namespace

std::string text_report(const SetDiagnosis& s) {
  std::string out;
  auto it = std::back_inserter(out);
  std::size_t runs = 0;
  for (const Diagnosis& d : s.plane_diagnoses) runs += d.runs;
  fmt::format_to(it, "Diagnosis of the test set {}: planes {}, {} runs", s.source,
                 plane_list(s.planes), runs);
  if (!s.feeds_mm_per_min.empty()) {
    out += ", feeds";
    for (double f : s.feeds_mm_per_min) fmt::format_to(it, " {:.0f}", f);
    out += " mm/min";
  }
  out += s.joint_fit ? "\n(joint value: one least-squares model across the set, each axis from "
                       "every plane it is in; each plane's own in brackets; +- one standard "
                       "error)\n\n"
                     : "\n(joint value from every plane the axis is in, each plane's own in "
                       "brackets; +- one standard error)\n\n";
  for (const AxisJoint& a : s.axes) {
    fmt::format_to(it, "  {} axis\n", a.axis);
    joint_line(out, "backlash", a.backlash_mm, 1e3, "um");
    joint_line(out, "reversal spike", a.spike_mm, 1e3, "um");
    joint_line(out, "reversal spike decay", a.spike_ms, 1.0, "ms");
    joint_line(out, "scale", a.scale_ppm, 1.0, "ppm");
    joint_line(out, "following lag", a.lag_ms, 1.0, "ms");
  }
  out += "  squareness\n";
  for (Plane p : {Plane::XY, Plane::YZ, Plane::ZX}) {
    const auto& e = s.squareness_urad[plane_index(p)];
    if (!e) continue;
    const PlaneAxes ax = plane_axes(p);
    fmt::format_to(it, "    {} {} ({} += angle * {})\n", plane_name(p),
                   estimate_text(*e, 1.0, "urad"), static_cast<char>(ax.first),
                   static_cast<char>(ax.second));
  }
  for (const std::string& n : s.notes) fmt::format_to(it, "Note: {}\n", n);
  for (const Diagnosis& d : s.plane_diagnoses) {
    out += '\n';
    out += text_report(d);
  }
  return out;
}

}  // namespace circtest
