// Writes a simulated circular-test trace (tests/support/machine_sim) for benchmarks,
// CLI tests and the bundled example: `circtest-simtrace -o out.csv --backlash-x 0.02 ...`.
#include <boost/program_options.hpp>
#include <iostream>
#include <sstream>

#include "circtest/core/cli.hpp"
#include "circtest/core/error.hpp"
#include "machine_sim.hpp"

namespace po = boost::program_options;
using namespace circtest;

int main(int argc, char** argv) {
  return run_cli("circtest-simtrace", [&]() -> int {
    sim::MachineModel m;
    sim::CircleProgram p;
    std::string out, plane = "XY";
    double d = 150.0;
    po::options_description desc("circtest-simtrace");
    desc.add_options()("help", "")("output,o", po::value(&out)->required(), "output trace")(
        "d", po::value(&d), "diameter mm")("f", po::value(&p.feed_mm_per_min), "feed mm/min")(
        "plane", po::value(&plane), "XY|YZ|ZX")("period", po::value(&p.period_s), "s")(
        "lead", po::value(&p.lead_deg), "deg")("arc", po::value(&p.arc_deg), "deg")(
        "cx", po::value(&p.centre_mm[0]), "")("cy", po::value(&p.centre_mm[1]), "")(
        "cz", po::value(&p.centre_mm[2]), "")("kv-x", po::value(&m.x.kv_per_s), "1/s")(
        "kv-y", po::value(&m.y.kv_per_s), "1/s")("kv-z", po::value(&m.z.kv_per_s), "1/s")(
        "backlash-x", po::value(&m.x.backlash_mm), "mm")(
        "backlash-y", po::value(&m.y.backlash_mm), "mm")("scale-x", po::value(&m.x.scale), "")(
        "scale-y", po::value(&m.y.scale), "")("squareness", po::value(&m.squareness_rad), "rad")(
        "spike-x", po::value(&m.x.spike_mm), "mm")("spike-ms-x", po::value(&m.x.spike_ms), "ms")(
        "spike-y", po::value(&m.y.spike_mm), "mm")("spike-ms-y", po::value(&m.y.spike_ms), "ms")(
        "cyclic-x", po::value(&m.x.cyclic_amplitude_mm), "mm")(
        "pitch-x", po::value(&m.x.cyclic_pitch_mm), "mm")(
        "cyclic-y", po::value(&m.y.cyclic_amplitude_mm), "mm")(
        "pitch-y", po::value(&m.y.cyclic_pitch_mm), "mm")("noise", po::value(&m.noise_mm), "mm")(
        "seed", po::value(&m.seed), "")("backlash-z", po::value(&m.z.backlash_mm), "mm")(
        "scale-z", po::value(&m.z.scale), "")("squareness-xy", po::value(&m.squareness_xy_rad),
                                              "rad")("squareness-yz",
                                                     po::value(&m.squareness_yz_rad), "rad")(
        "squareness-zx", po::value(&m.squareness_zx_rad), "rad")(
        "set", po::value<std::string>(),
        "a test set of these planes in this order (XY,YZ,ZX), CCW and CW at every feed")(
        "feeds", po::value<std::string>(), "with --set: the feeds, mm/min (500,1000)")(
        "radial", "add a ball bar's length column r")(
        "bar-length", po::value<double>(), "with --radial: r is the change from this length, mm");
    po::variables_map vm;
    try {
      po::store(po::parse_command_line(argc, argv, desc), vm);
      if (vm.count("help")) {
        std::cout << desc;
        return 0;
      }
      po::notify(vm);
    } catch (const po::error& e) {
      throw UsageError(e.what());
    }
    const auto pl = parse_plane(plane);
    if (!pl) throw UsageError("--plane: expected XY, YZ or ZX");
    p.plane = *pl;
    p.radius_mm = d / 2.0;
    p.radial = vm.count("radial") > 0;
    if (vm.count("bar-length")) p.bar_length_mm = vm["bar-length"].as<double>();
    if (vm.count("set")) {
      const auto planes = parse_plane_list(vm["set"].as<std::string>());
      if (!planes) throw UsageError("--set: expected planes each once, e.g. XY,YZ,ZX");
      std::vector<double> feeds;
      std::istringstream in(vm.count("feeds") ? vm["feeds"].as<std::string>()
                                              : std::to_string(p.feed_mm_per_min));
      for (std::string item; std::getline(in, item, ',');) feeds.push_back(std::stod(item));
      sim::TestSetProgram set;
      p.runs.clear();
      for (double f : feeds) {
        for (Direction dir : {Direction::CCW, Direction::CW}) {
          p.runs.push_back(dir);
          p.run_feeds_mm_per_min.push_back(f);
        }
      }
      for (Plane each : *planes) {
        p.plane = each;
        set.planes.push_back(p);
      }
      write_trace(out, sim::simulate_set(m, set));
      return 0;
    }
    Trace t = sim::simulate(m, p);
    write_trace(out, t);
    return 0;
  });
}
