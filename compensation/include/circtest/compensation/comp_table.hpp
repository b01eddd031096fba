#pragma once
// LinuxCNC 2.9 joint compensation tables ([JOINT_n] COMP_FILE, COMP_FILE_TYPE), with the rules
// motion applies (usrmotLoadComp, control.c): one "nominal a b" triplet a line, reading stops
// at the first line that is not three numbers (so a comment before the data disables the
// table), at most 256 entries, nominal strictly increasing. Type 0: a and b are the actual
// positions moving forward and in reverse (trim = nominal - actual); type 1: a and b are the
// trims added to the motor command. Beyond the table the end entries' trims hold.
#include <string>
#include <vector>

namespace circtest::compensation {

constexpr std::size_t kMaxCompEntries = 256;

struct CompEntry {
  double nominal = 0.0;
  double forward_trim = 0.0;  // added to the motor command while moving up
  double reverse_trim = 0.0;  // ... while moving down
};

struct CompTable {
  int type = 1;
  std::vector<CompEntry> entries;  // strictly increasing nominal
  // The trims LinuxCNC applies at POSITION (linear between entries, constant beyond).
  CompEntry at(double position) const;
};

// Throws ParseError (file:line) for a table LinuxCNC would silently cut short or refuse: a
// comment or text line before or between the data, more than 256 entries, nominal not
// strictly increasing, no entry at all. Blank lines only at the end.
CompTable parse_comp_table(const std::string& text, int type, const std::string& source);
// Writes the table in its type, full precision, no comments.
std::string render_comp_table(const CompTable& table);

}  // namespace circtest::compensation
