#pragma once
// LinuxCNC's parameter file (the .var file of [RS274NGC] PARAMETER_FILE), read as LinuxCNC
// 2.9 reads it: the work offsets circgen checks a test in.
#include <array>
#include <optional>
#include <string>
#include <string_view>

namespace circtest {

// The work offsets of a parameter file, in mm. LinuxCNC (rs274ngc_pre.cc restore_parameters
// and init) reads each line with sscanf("%d %lf"), the numbers increasing, every number not
// given 0: G54..G59.3 (index 1..9) have their origin at #5201+20n..#5203+20n and an XY
// rotation at #5210+20n; #5220 is the system selected when the file was saved, truncated
// (2.6 is G55), 1 when outside 1..9; #5210 non-zero says G92 applies, #5211..#5213 its offset,
// both cleared at start-up under [RS274NGC] DISABLE_G92_PERSISTENCE = 1.
struct WorkOffsets {
  std::string path;
  std::array<std::array<double, 3>, 10> origin_mm{};  // [1..9]
  std::array<double, 10> rotation_deg{};              // [1..9]
  int selected = 1;                                   // #5220
  bool g92_applied = false;                           // #5210
  std::array<double, 3> g92_mm{};                     // #5211..#5213
};

// What LinuxCNC restores of G92 at start-up.
enum class G92Persistence { kept, cleared };

// nullopt when the file does not exist (LinuxCNC then starts with every offset 0, until it
// writes one); IoError for a file that is not a regular one (a FIFO would never end).
// ParseError (file:line) for what LinuxCNC refuses (numbers out of order, a number outside
// 1..5601), for a value that is no finite number, and for every line LinuxCNC would read
// otherwise than it reads ("5221.0 180" is #5221 = 0 to LinuxCNC, "5221 180mm" is 180, a line
// over 254 characters is read in pieces).
std::optional<WorkOffsets> read_work_offsets(const std::string& path, double mm_per_unit,
                                             G92Persistence g92 = G92Persistence::kept);
WorkOffsets parse_work_offsets(const std::string& text, const std::string& path, double mm_per_unit,
                               G92Persistence g92 = G92Persistence::kept);

// "G54" -> 1 ... "G59.3" -> 9; 0 for anything else.
int work_offset_index(std::string_view code);

}  // namespace circtest
