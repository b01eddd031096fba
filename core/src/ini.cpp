#include "circtest/core/ini.hpp"

#include <sys/stat.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>

#include <fmt/format.h>

#include "circtest/core/error.hpp"
#include "circtest/core/input_file.hpp"
#include "circtest/core/strings.hpp"

namespace circtest {

namespace {

constexpr std::size_t kMaxFileBytes = 16u << 20;
constexpr std::size_t kMaxLineBytes = 1u << 20;

bool is_blank(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\n';
}

// The line end of a physical line ("\r\n", "\n" or "" at the end of the file).
std::string_view line_end(std::string_view physical) {
  if (physical.ends_with("\r\n")) return physical.substr(physical.size() - 2);
  if (physical.ends_with("\n")) return physical.substr(physical.size() - 1);
  return {};
}

// Reads a configuration file with bounds: a device or /dev/zero must not eat the memory, and a
// FIFO (which read_input_text would wait on) is no configuration file either.
std::string read_bounded(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    throw IoError(path, std::string("cannot open for reading: ") + std::strerror(errno));
  }
  if (!S_ISREG(st.st_mode)) {
    throw IoError(path, "not a regular file (expected a LinuxCNC INI file)");
  }
  if (static_cast<std::size_t>(st.st_size) > kMaxFileBytes) {
    throw IoError(path, "larger than 16 MiB: not a LinuxCNC INI file");
  }
  return read_input_text(path, kMaxFileBytes);
}

using Line = IniDocument::Line;

// The text LinuxCNC sees for a logical line: line ends dropped, continuation '\' removed.
std::string logical_text(std::string_view raw) {
  std::string out;
  std::size_t begin = 0;
  while (begin < raw.size()) {
    std::size_t end = raw.find('\n', begin);
    const bool last = end == std::string_view::npos || end + 1 == raw.size();
    std::string_view part =
        raw.substr(begin, end == std::string_view::npos ? raw.size() - begin : end - begin);
    if (!last && part.ends_with('\\')) part.remove_suffix(1);
    out.append(part);
    if (end == std::string_view::npos) break;
    begin = end + 1;
  }
  return out;
}

void classify(Line& line, bool main_file) {
  const std::string text = logical_text(line.raw);
  const std::string_view t = trim(text);
  line.name.clear();
  line.value.clear();
  if (t.empty()) {
    line.kind = Line::Kind::blank;
    return;
  }
  // scripts/linuxcnc: grep "^#INCLUDE", then `read a b` with a == "#INCLUDE".
  if (main_file && std::string_view(text).starts_with("#INCLUDE") &&
      (text.size() == 8 || is_blank(text[8]))) {
    line.kind = Line::Kind::include;
    line.value = std::string(trim(std::string_view(text).substr(8)));
    return;
  }
  if (t[0] == '#' || t[0] == ';') {
    line.kind = Line::Kind::comment;
    return;
  }
  if (t[0] == '[') {
    line.kind = Line::Kind::section;
    const auto close = t.find(']');
    line.name =
        std::string(t.substr(1, close == std::string_view::npos ? t.size() - 1 : close - 1));
    return;
  }
  const auto eq = t.find('=');
  if (eq == std::string_view::npos) {
    line.kind = Line::Kind::other;  // LinuxCNC never finds a value on such a line
    return;
  }
  std::size_t key_end = 0;
  while (key_end < t.size() && !is_blank(t[key_end]) && t[key_end] != '=') ++key_end;
  line.kind = Line::Kind::entry;
  line.name = std::string(t.substr(0, key_end));
  line.value = std::string(trim(t.substr(eq + 1)));
}

std::vector<Line> split_lines(std::string_view text, const std::string& source, bool main_file) {
  std::vector<Line> lines;
  std::size_t begin = 0;
  std::size_t line_no = 0;
  while (begin < text.size()) {
    Line line;
    line.line = line_no + 1;
    // Join physical lines while one ends in '\' just before its '\n' (LinuxCNC's rule).
    for (;;) {
      std::size_t end = text.find('\n', begin);
      end = end == std::string_view::npos ? text.size() : end + 1;
      ++line_no;
      if (end - begin > kMaxLineBytes) {
        throw ParseError(source, line_no, "line longer than 1 MiB: not a LinuxCNC INI file");
      }
      const std::string_view physical = text.substr(begin, end - begin);
      line.raw.append(physical);
      begin = end;
      const bool continues = physical.size() >= 2 && physical.ends_with("\\\n");
      if (!continues || begin >= text.size()) break;
    }
    classify(line, main_file);
    lines.push_back(std::move(line));
  }
  return lines;
}

std::string detect_newline(std::string_view text) {
  const auto lf = text.find('\n');
  if (lf != std::string_view::npos && lf > 0 && text[lf - 1] == '\r') return "\r\n";
  return "\n";
}

std::string expand_include_path(const std::string& target, const std::string& main_path) {
  namespace fs = std::filesystem;
  std::string p = target;
  if (p.starts_with("~/") || p == "~") {
    const char* home = std::getenv("HOME");
    p = std::string(home ? home : "") + p.substr(1);
  }
  fs::path path(p);
  if (path.is_relative()) {
    fs::path dir = fs::path(main_path).parent_path();
    path = dir.empty() ? path : dir / path;
  }
  return path.string();
}

bool section_matches(const Line& line, std::string_view section) {
  if (line.kind != Line::Kind::section) return false;
  // LinuxCNC compares "[SECTION]" with the start of the line after its blanks.
  const std::string text = logical_text(line.raw);
  const std::string_view t = trim(text);
  return t.size() >= section.size() + 2 && t[0] == '[' && t.substr(1, section.size()) == section &&
         t[section.size() + 1] == ']';
}

void check_value(std::string_view key, std::string_view value) {
  if (const auto problem = ini_edit_problem("X", key, value)) {
    throw Error(ExitCode::internal, "INI edit: " + *problem);
  }
}

void check_section(std::string_view section) {
  if (const auto problem = ini_edit_problem(section, "X", "")) {
    throw Error(ExitCode::internal, "INI edit: " + *problem);
  }
}

}  // namespace

std::optional<std::string> ini_edit_problem(std::string_view section, std::string_view key,
                                            std::string_view value) {
  const auto control = [](std::string_view s) {
    for (const char c : s) {
      if (static_cast<unsigned char>(c) < 0x20 && c != '\t') return true;
    }
    return false;
  };
  if (section.empty() || control(section) ||
      section.find_first_of("[]") != std::string_view::npos) {
    return fmt::format("'{}' is not a section name (expected no brackets and no line break)",
                       section);
  }
  if (key.empty() || key.find_first_of(" \t\r\n=[]#;") != std::string_view::npos || control(key)) {
    return fmt::format("'{}' is not a key name (expected no blank, '=', '[', ']', '#' or ';')",
                       key);
  }
  if (control(value) || value.ends_with('\\')) {
    return fmt::format(
        "the value of {} would span lines (a line break, a control character or a final '\\')",
        key);
  }
  return std::nullopt;
}

IniDocument IniDocument::parse(std::string_view text, std::string source) {
  IniDocument doc;
  File file;
  file.path = std::move(source);
  file.lines = split_lines(text, file.path, true);
  file.newline = detect_newline(text);
  doc.files_.push_back(std::move(file));
  return doc;
}

IniDocument IniDocument::load(const std::string& path) {
  IniDocument doc = parse(read_bounded(path), path);
  std::vector<std::pair<dev_t, ino_t>> seen;  // the files read so far: the INI first
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0) seen.emplace_back(st.st_dev, st.st_ino);
  for (std::size_t i = 0; i < doc.files_.front().lines.size(); ++i) {
    Line& line = doc.files_.front().lines[i];
    if (line.kind != Line::Kind::include) continue;
    const std::string where = path + ":" + std::to_string(line.line);
    // The linuxcnc script starts without an #INCLUDE it cannot read; the machine would then
    // run without those sections, so circtest refuses instead.
    if (line.value.empty()) {
      throw ParseError(path, line.line, "#INCLUDE without a file name");
    }
    const std::string target = expand_include_path(line.value, path);
    std::string text;
    try {
      text = read_bounded(target);
    } catch (const IoError& e) {
      throw IoError(where, "#INCLUDE " + line.value + ": " + e.what());
    }
    if (::stat(target.c_str(), &st) == 0) {
      for (const auto& [dev, ino] : seen) {
        if (dev == st.st_dev && ino == st.st_ino) {
          throw ParseError(path, line.line,
                           "#INCLUDE " + line.value + ": includes " +
                               (seen.front() == std::make_pair(dev, ino)
                                    ? std::string("the INI itself")
                                    : std::string("a file already included")) +
                               " (expected each file once)");
        }
      }
      seen.emplace_back(st.st_dev, st.st_ino);
    }
    File included;
    included.path = target;
    included.lines = split_lines(text, target, false);
    included.newline = detect_newline(text);
    for (const Line& nested : included.lines) {
      const std::string nested_text = logical_text(nested.raw);
      if (nested.kind == Line::Kind::comment && nested_text.starts_with("#INCLUDE") &&
          (nested_text.size() == 8 || is_blank(nested_text[8]))) {
        throw ParseError(target, nested.line,
                         "#INCLUDE inside an included file: LinuxCNC follows #INCLUDE only in "
                         "the main INI (one level), so " +
                             std::string(trim(std::string_view(nested_text).substr(8))) +
                             " would never be read (included from " + where + ")");
      }
    }
    line.included_file = doc.files_.size();
    doc.files_.push_back(std::move(included));
  }
  return doc;
}

std::vector<IniDocument::Ref> IniDocument::expanded() const {
  std::vector<Ref> view;
  const File& main = files_.front();
  for (std::size_t i = 0; i < main.lines.size(); ++i) {
    const Line& line = main.lines[i];
    if (line.kind == Line::Kind::include && line.included_file != 0) {
      const File& inc = files_[line.included_file];
      for (std::size_t j = 0; j < inc.lines.size(); ++j) view.push_back({line.included_file, j});
    } else {
      view.push_back({0, i});
    }
  }
  return view;
}

const IniDocument::Line& IniDocument::at(const Ref& ref) const {
  return files_[ref.file].lines[ref.line];
}

std::optional<std::pair<std::size_t, std::size_t>> IniDocument::section_span(
    const std::vector<Ref>& view, std::string_view section) const {
  for (std::size_t i = 0; i < view.size(); ++i) {
    if (!section_matches(at(view[i]), section)) continue;
    std::size_t j = i + 1;
    while (j < view.size() && at(view[j]).kind != Line::Kind::section) ++j;
    return std::make_pair(i, j);
  }
  return std::nullopt;
}

std::optional<std::size_t> IniDocument::find_index(const std::vector<Ref>& view,
                                                   std::string_view section, std::string_view key,
                                                   std::size_t nth) const {
  const auto span = section_span(view, section);
  if (!span) return std::nullopt;
  for (std::size_t i = span->first + 1; i < span->second; ++i) {
    const Line& line = at(view[i]);
    if (line.kind == Line::Kind::entry && line.name == key && nth-- == 0) return i;
  }
  return std::nullopt;
}

IniEntry IniDocument::entry_of(const Ref& ref, std::string_view section) const {
  const Line& line = at(ref);
  return IniEntry{std::string(section), line.name, line.value, files_[ref.file].path, line.line};
}

std::optional<std::string> IniDocument::get(std::string_view section, std::string_view key) const {
  const auto entry = find(section, key);
  // LinuxCNC reports "KEY =" with nothing after it as not found.
  if (!entry || entry->value.empty()) return std::nullopt;
  return entry->value;
}

std::optional<IniEntry> IniDocument::find(std::string_view section, std::string_view key) const {
  const auto view = expanded();
  const auto index = find_index(view, section, key);
  if (!index) return std::nullopt;
  return entry_of(view[*index], section);
}

std::vector<IniEntry> IniDocument::get_all(std::string_view section, std::string_view key) const {
  std::vector<IniEntry> out;
  for (IniEntry& e : entries(section)) {
    if (e.key == key) out.push_back(std::move(e));
  }
  return out;
}

std::vector<IniEntry> IniDocument::entries(std::string_view section) const {
  std::vector<IniEntry> out;
  const auto view = expanded();
  const auto span = section_span(view, section);
  if (!span) return out;
  for (std::size_t i = span->first + 1; i < span->second; ++i) {
    if (at(view[i]).kind == Line::Kind::entry) out.push_back(entry_of(view[i], section));
  }
  return out;
}

bool IniDocument::has_section(std::string_view section) const {
  return section_span(expanded(), section).has_value();
}

std::vector<std::string> IniDocument::sections() const {
  std::vector<std::string> names;
  for (const Ref& ref : expanded()) {
    const Line& line = at(ref);
    if (line.kind != Line::Kind::section) continue;
    bool seen = false;
    for (const auto& n : names) seen = seen || n == line.name;
    if (!seen) names.push_back(line.name);
  }
  return names;
}

IniDocument::Line IniDocument::make_entry(std::size_t file, std::string_view key,
                                          std::string_view value) const {
  check_value(key, value);
  Line line;
  line.raw = std::string(key) + " = " + std::string(value) + files_[file].newline;
  classify(line, file == 0);
  return line;
}

void IniDocument::insert_line(const Ref& before, Line line) {
  File& file = files_[before.file];
  // The line before may be the last one of the file, without a line end.
  if (before.line > 0) {
    Line& prev = file.lines[before.line - 1];
    if (!prev.raw.ends_with('\n')) prev.raw += file.newline;
  }
  file.lines.insert(file.lines.begin() + static_cast<std::ptrdiff_t>(before.line), std::move(line));
  // Keep physical line numbers meaningful for later messages.
  std::size_t no = 1;
  for (Line& l : file.lines) {
    l.line = no;
    for (char c : l.raw) no += c == '\n';
    if (!l.raw.ends_with('\n')) ++no;
  }
  file.modified = true;
}

void IniDocument::set(std::string_view section, std::string_view key, std::string_view value) {
  const auto view = expanded();
  if (const auto index = find_index(view, section, key)) {
    check_value(key, value);
    const Ref ref = view[*index];
    Line& line = files_[ref.file].lines[ref.line];
    // Keep "KEY<blanks>=<blanks>" of the first physical line and the last line's end.
    const std::string_view first = std::string_view(line.raw).substr(0, line.raw.find('\n'));
    const auto eq = first.find('=');
    std::string prefix;
    if (eq != std::string_view::npos) {
      std::size_t v = eq + 1;
      while (v < first.size() && (first[v] == ' ' || first[v] == '\t')) ++v;
      prefix = std::string(first.substr(0, v));
      if (v == eq + 1 && v == first.size()) prefix += ' ';
    } else {
      prefix = std::string(key) + " = ";
    }
    std::string end(line_end(line.raw));
    if (end.empty() && ref.line + 1 < files_[ref.file].lines.size()) end = files_[ref.file].newline;
    const std::string raw = prefix + std::string(value) + end;
    if (raw == line.raw) return;
    line.raw = raw;
    classify(line, ref.file == 0);
    files_[ref.file].modified = true;
    return;
  }
  append(section, key, value);
}

void IniDocument::append(std::string_view section, std::string_view key, std::string_view value) {
  const auto view = expanded();
  const auto span = section_span(view, section);
  if (!span) {
    check_section(section);
    check_value(key, value);
    File& main = files_.front();
    if (!main.lines.empty() && !main.lines.back().raw.ends_with('\n')) {
      main.lines.back().raw += main.newline;
    }
    const Ref end{0, main.lines.size()};
    if (!main.lines.empty() && main.lines.back().kind != Line::Kind::blank) {
      Line blank;
      blank.raw = main.newline;
      classify(blank, true);
      insert_line({0, main.lines.size()}, std::move(blank));
    }
    Line header;
    header.raw = std::string("[").append(section).append("]").append(main.newline);
    classify(header, true);
    insert_line({0, files_.front().lines.size()}, std::move(header));
    insert_line({0, files_.front().lines.size()}, make_entry(0, key, value));
    (void)end;
    return;
  }
  // After the last occurrence of KEY, else after the section's last entry, else after its
  // header; blank lines and comments that end the section stay where they are.
  std::size_t after = span->first;
  std::size_t last_key = 0;
  for (std::size_t i = span->first + 1; i < span->second; ++i) {
    const Line& line = at(view[i]);
    if (line.kind == Line::Kind::entry || line.kind == Line::Kind::other) after = i;
    if (line.kind == Line::Kind::entry && line.name == key) last_key = i;
  }
  if (last_key != 0) after = last_key;
  const Ref ref = view[after];
  insert_line({ref.file, ref.line + 1}, make_entry(ref.file, key, value));
}

bool IniDocument::remove(std::string_view section, std::string_view key) {
  const auto view = expanded();
  const auto index = find_index(view, section, key);
  if (!index) return false;
  const Ref ref = view[*index];
  File& file = files_[ref.file];
  file.lines.erase(file.lines.begin() + static_cast<std::ptrdiff_t>(ref.line));
  file.modified = true;
  return true;
}

bool IniDocument::remove_value(std::string_view section, std::string_view key,
                               std::string_view value) {
  const auto view = expanded();
  for (std::size_t nth = 0;; ++nth) {
    const auto index = find_index(view, section, key, nth);
    if (!index) return false;
    const Ref ref = view[*index];
    if (at(ref).value != value) continue;
    File& file = files_[ref.file];
    file.lines.erase(file.lines.begin() + static_cast<std::ptrdiff_t>(ref.line));
    file.modified = true;
    return true;
  }
}

void IniDocument::comment_before(std::string_view section, std::string_view key,
                                 std::string_view text) {
  const auto view = expanded();
  const auto index = find_index(view, section, key);
  if (!index) {
    throw Error(ExitCode::internal, "INI edit: no " + std::string(key) + " in [" +
                                        std::string(section) + "] to comment");
  }
  if (text.find_first_of("\r\n") != std::string_view::npos) {
    throw Error(ExitCode::internal, "INI edit: a comment must be one line");
  }
  const Ref ref = view[*index];
  Line line;
  line.raw = "# " + std::string(text) + files_[ref.file].newline;
  classify(line, ref.file == 0);
  insert_line(ref, std::move(line));
}

std::string IniDocument::render_file(std::size_t index) const {
  std::string out;
  for (const Line& line : files_.at(index).lines) out += line.raw;
  return out;
}

std::string IniDocument::render() const {
  return render_file(0);
}

}  // namespace circtest
