#include "circtest/session/commands.hpp"

#include <ostream>

#include "circtest/compensation/plan.hpp"

namespace circtest::session {

int install_command(const InstallRequest& request, const Console& console) {
  const InstallPlan plan = plan_install(request);
  std::ostream& out = console.print();
  out << compensation::unified_diff(plan.plan);
  for (std::size_t i = 0; i < plan.channels.size(); ++i) {
    const InstallChannel& c = plan.channels[i];
    out << "# channel " << i << " " << c.column << ": "
        << (c.pin.empty() ? "signal " + c.signal : c.pin) << " (" << c.what << ")\n";
  }
  for (const std::string& n : plan.notes) out << "# note: " << n << "\n";
  if (!console.confirm("circtest: write these changes into " + request.ini_path + "?")) {
    out << "circtest: nothing written (answer y on a terminal, or give the yes option)\n";
    return 0;
  }
  apply_install(plan);
  for (const auto& f : plan.plan.files) {
    out << "circtest: " << (f.existed ? "changed " : "created ") << f.path << "\n";
  }
  out << "circtest: originals kept in .circcomp/; restart LinuxCNC to load circlog\n";
  return 0;
}

int uninstall_command(const std::string& ini_path, const Console& console) {
  std::ostream& out = console.print();
  if (!uninstall(ini_path)) {
    out << "circtest: nothing installed in " << ini_path << "\n";
    return 0;
  }
  out << "circtest: circlog removed from " << ini_path
      << " (the files as they were before install); restart LinuxCNC\n";
  return 0;
}

}  // namespace circtest::session
