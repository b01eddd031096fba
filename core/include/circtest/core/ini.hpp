#pragma once
// The one INI reader of circtest: a lossless document of a LinuxCNC 2.9 configuration.
//
// Reading follows LinuxCNC 2.9 (libnml/inifile, scripts/linuxcnc): names are case-sensitive;
// a key is found in the first [SECTION] of that name, up to the next line starting with '[';
// the first occurrence of a key wins (get_all() returns every one, as for [HAL]HALFILE); a
// line ending in a backslash continues on the next; lines starting with '#' or ';' are
// comments, lines without '=' are ignored; a "#INCLUDE FILE" line at the start of a line of
// the main file is replaced by FILE's text (relative to the INI's folder, '~' is $HOME; one
// level, as the linuxcnc script does). Where the linuxcnc script would start without an
// #INCLUDE (it cannot be read) or never read one (nested in an included file), load() refuses.
//
// Writing changes only the lines an edit means: every other byte (comments, blank lines, key
// order, spacing, CRLF line ends, continuation lines, included files) renders back unchanged.
// An edit of a key that lives in an included file changes that file.
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace circtest {

// What makes an edit impossible to write as one INI line: a section name with a bracket or a
// line break, a key with a blank, '=', '[', ']', '#' or ';', a value with a line break or a
// control character or ending in '\' (a continuation); nullopt when the edit is fine.
std::optional<std::string> ini_edit_problem(std::string_view section, std::string_view key,
                                            std::string_view value);

// One key = value as LinuxCNC reads it.
struct IniEntry {
  std::string section;
  std::string key;
  std::string value;     // after '=', blanks trimmed, continuation lines joined
  std::string file;      // the file holding the line (the INI or an included file)
  std::size_t line = 0;  // 1-based first physical line in that file
};

class IniDocument {
 public:
  // Reads PATH and the files it #INCLUDEs. Throws IoError (missing, not a regular file,
  // larger than 16 MiB; for an #INCLUDE that cannot be read, the message starts with the INI's
  // FILE:LINE) or ParseError (a line longer than 1 MiB; an #INCLUDE without a name, of the
  // INI itself or of a file already included; an #INCLUDE inside an included file).
  static IniDocument load(const std::string& path);
  // Parses TEXT as the file SOURCE; #INCLUDE lines are kept as text but not followed.
  static IniDocument parse(std::string_view text, std::string source = "<ini>");

  // --- reading (the expanded view, includes in place) ---
  std::optional<std::string> get(std::string_view section, std::string_view key) const;
  std::optional<IniEntry> find(std::string_view section, std::string_view key) const;
  std::vector<IniEntry> get_all(std::string_view section, std::string_view key) const;
  std::vector<IniEntry> entries(std::string_view section) const;  // in file order
  bool has_section(std::string_view section) const;
  std::vector<std::string> sections() const;  // each name once, in first-seen order

  // --- editing ---
  // Replaces the value of the first occurrence (keeping the key's spelling, the blanks around
  // '=' and the line end), or adds KEY = VALUE at the end of the section's entries, or adds
  // the section at the end of the main file.
  void set(std::string_view section, std::string_view key, std::string_view value);
  // Adds another KEY = VALUE after the section's last occurrence of KEY (or its last entry).
  void append(std::string_view section, std::string_view key, std::string_view value);
  // Removes the first occurrence of KEY; false when there is none.
  bool remove(std::string_view section, std::string_view key);
  // Removes the occurrence of KEY whose value is VALUE; false when there is none.
  bool remove_value(std::string_view section, std::string_view key, std::string_view value);
  // Puts "# TEXT" on its own line just before the first occurrence of KEY (which must exist).
  void comment_before(std::string_view section, std::string_view key, std::string_view text);

  // --- writing ---
  std::string render() const;                               // the main file
  std::size_t file_count() const { return files_.size(); }  // main file first, then includes
  const std::string& file_path(std::size_t index) const { return files_.at(index).path; }
  std::string render_file(std::size_t index) const;
  bool file_modified(std::size_t index) const { return files_.at(index).modified; }
  const std::string& path() const { return files_.front().path; }

  struct Line;  // a logical line: one physical line, or several joined by '\'

 private:
  struct File {
    std::string path;
    std::vector<Line> lines;
    std::string newline = "\n";  // for added lines: CRLF when the file uses it
    bool modified = false;
  };
  // Position of a logical line in the expanded view.
  struct Ref {
    std::size_t file;
    std::size_t line;
  };
  std::vector<Ref> expanded() const;
  std::optional<std::pair<std::size_t, std::size_t>> section_span(const std::vector<Ref>& view,
                                                                  std::string_view section) const;
  std::optional<std::size_t> find_index(const std::vector<Ref>& view, std::string_view section,
                                        std::string_view key, std::size_t nth = 0) const;
  const Line& at(const Ref& ref) const;
  void insert_line(const Ref& before, Line line);
  Line make_entry(std::size_t file, std::string_view key, std::string_view value) const;
  IniEntry entry_of(const Ref& ref, std::string_view section) const;

  std::vector<File> files_;
};

struct IniDocument::Line {
  enum class Kind { blank, comment, section, entry, include, other };
  std::string raw;  // every byte of the physical lines, line ends included
  Kind kind = Kind::other;
  std::string name;   // section name, or key
  std::string value;  // entry value, or include target
  std::size_t line = 0;
  std::size_t included_file = 0;  // for an include that was followed: index into files_
};

}  // namespace circtest
