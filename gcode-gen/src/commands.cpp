#include "circtest/gcode/commands.hpp"

#include "circtest/core/atomic_file.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/strings.hpp"
#include "circtest/core/trace_keys.hpp"
#include "circtest/gcode/machine_limits.hpp"

namespace circtest {

int run_generate(GenerateRequest request, std::ostream& out, std::ostream& err) {
  CircleTestSpec& spec = request.spec;
  validate(spec);
  if (!request.ini_path.empty()) {
    const MachineLimits limits = read_machine_limits(request.ini_path);
    const auto checks = check_against_machine(spec, limits, request.work_offset_origin_mm);
    spec.extra_header.emplace_back(meta_key::ini, request.ini_path);
    spec.extra_header.emplace_back(meta_key::ini_checked, join(checks));
  }

  const TestProgram program = generate_test_program(spec);
  for (const std::string& warning : program_warnings(spec)) {
    err << "circgen: warning: " << warning << '\n';
  }
  if (!request.output_path.empty()) {
    write_file_atomic(request.output_path, program.text);
  } else {
    out.write(program.text.data(), static_cast<std::streamsize>(program.text.size()));
    out.flush();
    if (!out) throw IoError("<stdout>", "write failed");
  }
  return 0;
}

}  // namespace circtest
