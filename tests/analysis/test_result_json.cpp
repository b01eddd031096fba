// The result JSON contract (schema circtest.evaluation/1): what circana analyze --json
// prints is read back into the same Evaluation, and a document of another shape is refused.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "circtest/analysis/evaluation.hpp"
#include "circtest/analysis/result_json.hpp"
#include "expect_error.hpp"
#include "machine_sim.hpp"

using namespace circtest;
using json = nlohmann::ordered_json;

namespace {

// A machine with backlash, squareness and a temperature, evaluated with the set-up centre:
// every optional of the document is filled (F, feed, temperatures, centre, H pairs).
Evaluation simulated_evaluation(bool with_temperature) {
  sim::MachineModel m;
  m.x.backlash_mm = 0.01;
  m.squareness_rad = 50e-6;
  m.noise_mm = 0.0002;
  sim::CircleProgram p;
  p.runs = {Direction::CCW, Direction::CW, Direction::CCW};
  EvaluationOptions o;
  if (with_temperature) o.temperatures.machine_C = 21.5;
  o.f_centre = FCentre::nominal;
  return evaluate(sim::simulate(m, p), o);
}

}  // namespace

TEST(ResultJson, SchemaKeyComesFirst) {
  const json j = to_json(simulated_evaluation(false));
  ASSERT_FALSE(j.empty());
  EXPECT_EQ(j.begin().key(), "schema");
  EXPECT_EQ(j["schema"], "circtest.evaluation/1");
}

TEST(ResultJson, FromJsonRoundTripsToTheSameDocument) {
  for (bool temperature : {false, true}) {
    SCOPED_TRACE(temperature);
    const Evaluation ev = simulated_evaluation(temperature);
    ASSERT_EQ(ev.runs.size(), 3u);
    ASSERT_FALSE(ev.hysteresis.empty());
    const json first = to_json(ev);
    const Evaluation back = evaluation_from_json(first);
    EXPECT_EQ(to_json(back).dump(2), first.dump(2));
    // Through text, as a reader of circana's output gets it.
    const Evaluation parsed = evaluation_from_json(json::parse(first.dump(2)));
    EXPECT_EQ(to_json(parsed).dump(), first.dump());
    // The numbers that matter, exactly.
    EXPECT_EQ(parsed.hysteresis.front().h_mm, ev.hysteresis.front().h_mm);
    EXPECT_EQ(parsed.runs[1].g_mzc_mm, ev.runs[1].g_mzc_mm);
    EXPECT_EQ(*parsed.runs[2].f_max_mm, *ev.runs[2].f_max_mm);
    EXPECT_EQ(parsed.runs[0].run.size(), ev.runs[0].run.size());
    EXPECT_EQ(parsed.runs[0].last_line, ev.runs[0].last_line);
    EXPECT_EQ(parsed.centre, ev.centre);
    EXPECT_EQ(parsed.temperatures.machine_C, ev.temperatures.machine_C);
  }
}

TEST(ResultJson, RefusesAnotherSchemaOrAMissingKey) {
  json j = to_json(simulated_evaluation(false));
  json other = j;
  other["schema"] = "circtest.evaluation/2";
  EXPECT_ERROR(evaluation_from_json(other, "r.json"), ExitCode::parse,
               "r.json: result JSON 'schema': expected 'circtest.evaluation/1', got "
               "'circtest.evaluation/2'");
  json missing = j;
  missing["runs"][1].erase("G");
  EXPECT_ERROR(evaluation_from_json(missing, "r.json"), ExitCode::parse,
               "result JSON 'runs[1].G': expected a value (missing)");
  json wrong = j;
  wrong["pairs"][0]["runs"] = json::array({0, 7});
  EXPECT_ERROR(evaluation_from_json(wrong), ExitCode::parse, "'pairs[0].runs'");
  json source = j;
  source["nominal_centre_source"] = "guessed";
  EXPECT_ERROR(evaluation_from_json(source), ExitCode::parse,
               "'nominal_centre_source': expected option, metadata, commanded or empty");
  json f_centre = j;
  f_centre["runs"][0]["F_centre"] = "auto";
  EXPECT_ERROR(evaluation_from_json(f_centre), ExitCode::parse,
               "'runs[0].F_centre': expected lsc or nominal");
}

TEST(ResultJson, RefusesNumbersNoEvaluationReportsNamingTheKey) {
  const json j = to_json(simulated_evaluation(false));
  json huge = j;
  huge["pairs"][0]["H"] = 1e300;
  EXPECT_ERROR(evaluation_from_json(huge, "r.json"), ExitCode::data,
               "r.json: result JSON 'pairs[0].H': 1e+300 is not a usable number (at most 1e+09 "
               "in size)");
  json centre = j;
  centre["runs"][1]["centre"][1] = -2e9;
  EXPECT_ERROR(evaluation_from_json(centre, "r.json"), ExitCode::data,
               "'runs[1].centre[1]': -2e+09 is not a usable number");
  json temperature = j;
  temperature["temperature"]["machine_C"] = 1e12;
  EXPECT_ERROR(evaluation_from_json(temperature, "r.json"), ExitCode::data,
               "'temperature.machine_C': 1e+12");
}
