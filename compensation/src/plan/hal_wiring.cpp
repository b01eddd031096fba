// The configuration's HAL files read as halcmd runs them: words with [SECTION]KEY replaced
// from the INI, signals and their pins, the commands that set values (setp, "PIN = VALUE",
// sets), loaded modules and each thread's functions.
#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <set>
#include <sstream>

#include "circtest/compensation/friction.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/numbers.hpp"
#include "context.hpp"

namespace circtest::compensation {

namespace fs = std::filesystem;
using namespace detail;

namespace {

bool is_arrow(const std::string& w) {
  return w == "=>" || w == "<=" || w == "<=>";
}

bool ini_key_char(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_';
}

// WORD with every [SECTION]KEY and [SECTION](KEY) replaced by the INI's value (kept as it is
// when the INI has none). A scan, not a regular expression: a word of megabytes is read in
// linear time and constant stack.
std::string substituted(const std::string& w, const IniDocument& ini) {
  std::string out;
  std::size_t i = 0;
  std::size_t close = 0;  // the first ']' after the last '[' looked at (found once per ']')
  while (i < w.size()) {
    const std::size_t open = w.find('[', i);
    if (open == std::string::npos) break;
    if (close <= open) close = w.find(']', open + 1);
    if (close == std::string::npos) break;
    if (close == open + 1 || w.find('[', open + 1) < close) {
      out.append(w, i, open + 1 - i);
      i = open + 1;
      continue;
    }
    std::size_t k = close + 1;
    const bool paren = k < w.size() && w[k] == '(';
    if (paren) ++k;
    const std::size_t key_begin = k;
    while (k < w.size() && ini_key_char(w[k])) ++k;
    const bool closed = !paren || (k < w.size() && w[k] == ')');
    if (k == key_begin || !closed) {
      out.append(w, i, close + 1 - i);
      i = close + 1;
      continue;
    }
    const std::size_t end = paren ? k + 1 : k;
    out.append(w, i, open - i);
    const auto v = ini.get(std::string_view(w).substr(open + 1, close - open - 1),
                           std::string_view(w).substr(key_begin, k - key_begin));
    out += v ? *v : w.substr(open, end - open);
    i = end;
  }
  out.append(w, i);
  return out;
}

// halcmd's words of one logical line: blanks split, '#' at a word's start ends the line,
// [SECTION]KEY words replaced from the INI.
std::vector<std::string> hal_words(const std::string& line, const IniDocument& ini) {
  std::vector<std::string> words;
  std::istringstream in(line);
  for (std::string w; in >> w;) {
    if (w.front() == '#') break;
    words.push_back(w.find('[') == std::string::npos ? w : substituted(w, ini));
  }
  return words;
}

void link_pin(HalWiring& w, const std::string& signal, const std::string& pin,
              const HalPlace& place) {
  auto [it, fresh] = w.signals.try_emplace(signal);
  if (fresh) it->second.place = place;
  if (const auto old = w.pin_signal.find(pin); old != w.pin_signal.end()) {
    w.signals[old->second].pins.erase(pin);
  }
  it->second.pins.insert(pin);
  w.pin_signal[pin] = signal;
}

void add_function(HalWiring& w, const std::vector<std::string>& words, const HalPlace& place) {
  auto& list = w.threads[words[2]];
  long position = -1;
  if (words.size() > 3) {
    const auto v = parse_finite(words[3]);
    if (!v || *v != std::floor(*v) || *v == 0 || std::fabs(*v) > 1e6) {
      throw ParseError(place.file, place.line,
                       fmt::format("addf {} {} {}: expected a position (1 = first, -1 = last)",
                                   words[1], words[2], words[3]));
    }
    position = static_cast<long>(*v);
  }
  const long size = static_cast<long>(list.size());
  long index = position > 0 ? position - 1 : size + 1 + position;
  index = std::clamp(index, 0L, size);
  list.insert(list.begin() + index, words[1]);
  w.addf[words[1]] = place;
}

void load_module(HalWiring& w, const std::vector<std::string>& words, const HalPlace& place) {
  if (words[1] == "circfric") w.loads_circfric = place;
  if (words[1] != "pid") return;
  bool named = false;
  int count = 3;  // pid's default
  for (std::size_t i = 2; i < words.size(); ++i) {
    if (words[i].starts_with("names=")) {
      named = true;
      std::istringstream in(words[i].substr(6));
      for (std::string n; std::getline(in, n, ',');) w.pid_instances.push_back(n);
    } else if (words[i].starts_with("num_chan=")) {
      count = static_cast<int>(std::clamp(parse_finite(words[i].substr(9)).value_or(3), 0.0, 64.0));
    }
  }
  for (int i = 0; !named && i < count; ++i) {
    w.pid_instances.push_back(fmt::format("pid.{}", i));
  }
}

void need_words(const std::vector<std::string>& words, std::size_t n, const HalPlace& place,
                const std::string& form) {
  if (words.size() < n) {
    throw ParseError(place.file, place.line, fmt::format("expected '{}'", form));
  }
}

// Pins of WORDS from index FROM on, arrows left out.
std::vector<std::string> pins_from(const std::vector<std::string>& words, std::size_t from) {
  std::vector<std::string> pins;
  for (std::size_t i = from; i < words.size(); ++i) {
    if (!is_arrow(words[i])) pins.push_back(words[i]);
  }
  return pins;
}

// A word halcmd reads as a command, not as the PIN of "PIN = VALUE" (halcmd_commands.cc).
bool is_halcmd_command(const std::string& word) {
  static const std::set<std::string> kCommands{
      "addf",      "alias",     "delf",
      "delsig",    "echo",      "getp",
      "gets",      "help",      "linkpp",
      "linkps",    "linksp",    "list",
      "loadrt",    "loadusr",   "lock",
      "net",       "newsig",    "ptype",
      "quit",      "save",      "setexact_for_test_suite_only",
      "setp",      "sets",      "show",
      "source",    "start",     "status",
      "stop",      "stype",     "unalias",
      "unecho",    "unlinkp",   "unload",
      "unloadrt",  "unloadusr", "unlock",
      "waitusr",   "exit",      "newinst",
      "newthread", "delthread", "print"};
  return kCommands.count(word) > 0;
}

void hal_command(HalWiring& w, const std::vector<std::string>& words, const HalPlace& place) {
  const std::string& cmd = words[0];
  if (cmd == "loadrt") {
    need_words(words, 2, place, "loadrt MODULE [ARGS]");
    load_module(w, words, place);
  } else if (cmd == "net") {
    need_words(words, 2, place, "net SIGNAL PIN...");
    if (auto [it, fresh] = w.signals.try_emplace(words[1]); fresh) it->second.place = place;
    for (const auto& pin : pins_from(words, 2)) link_pin(w, words[1], pin, place);
  } else if (cmd == "linksp" || cmd == "linkps") {
    const auto rest = pins_from(words, 1);
    if (rest.size() != 2) throw ParseError(place.file, place.line, "expected '" + cmd + " A B'");
    if (cmd == "linksp") link_pin(w, rest[0], rest[1], place);
    if (cmd == "linkps") link_pin(w, rest[1], rest[0], place);
  } else if (cmd == "linkpp") {
    const auto rest = pins_from(words, 1);
    if (rest.size() != 2) throw ParseError(place.file, place.line, "expected 'linkpp PIN PIN'");
    link_pin(w, rest[0], rest[0], place);
    link_pin(w, rest[0], rest[1], place);
  } else if (cmd == "unlinkp") {
    need_words(words, 2, place, "unlinkp PIN");
    if (const auto it = w.pin_signal.find(words[1]); it != w.pin_signal.end()) {
      w.signals[it->second].pins.erase(words[1]);
      w.pin_signal.erase(it);
    }
  } else if (cmd == "setp" || cmd == "sets") {
    need_words(words, 3, place, cmd + " NAME VALUE");
    (cmd == "setp" ? w.setp : w.sets)[words[1]] = place;
  } else if (words.size() == 3 && words[1] == "=" && !is_halcmd_command(cmd)) {
    w.setp[words[0]] = place;  // halcmd(1): "PIN = VALUE" is "setp PIN VALUE"
  } else if (cmd == "addf") {
    need_words(words, 3, place, "addf FUNCTION THREAD [POSITION]");
    add_function(w, words, place);
  } else if (cmd == "delf") {
    need_words(words, 2, place, "delf FUNCTION [THREAD]");
    for (auto& [thread, list] : w.threads) {
      if (words.size() > 2 && thread != words[2]) continue;
      list.erase(std::remove(list.begin(), list.end(), words[1]), list.end());
    }
  }
}

// A pin circfric is spliced in front of: a pid's command or a stepgen's position command.
}  // namespace

HalWiring parse_hal_text(const std::string& text, const std::string& file, const IniDocument& ini,
                         HalWiring wiring) {
  std::istringstream in(text);
  std::size_t number = 0;
  std::string logical;
  std::size_t first = 0;
  for (std::string line; std::getline(in, line);) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (logical.empty()) first = number;
    if (!line.empty() && line.back() == '\\') {
      logical += line.substr(0, line.size() - 1) + " ";
      continue;
    }
    logical += line;
    const auto words = hal_words(logical, ini);
    logical.clear();
    if (!words.empty()) hal_command(wiring, words, {file, first});
  }
  wiring.read.push_back(file);
  return wiring;
}

namespace {

// The .hal files of ENTRIES read into WIRING in order (SKIP and other kinds left unread).
void read_hal_files(const IniDocument& ini, const std::vector<IniEntry>& entries,
                    const std::string& skip, HalWiring& wiring) {
  const std::string dir = ini_dir(ini.path());
  for (const auto& h : entries) {
    if (h.value == skip) continue;
    const fs::path path = fs::path(h.value).is_absolute() || dir.empty() ? fs::path(h.value)
                                                                         : fs::path(dir) / h.value;
    bool existed = false;
    const std::string text =
        fs::path(h.value).extension() == ".hal" ? slurp_if(path.string(), existed) : "";
    if (!existed) {
      wiring.unread.push_back(h.value);
      continue;
    }
    wiring = parse_hal_text(text, path.string(), ini, std::move(wiring));
  }
}

}  // namespace

HalWiring read_hal_wiring(const IniDocument& ini, const std::string& skip, bool and_later) {
  HalWiring wiring;
  read_hal_files(ini, ini.get_all("HAL", "HALFILE"), skip, wiring);
  if (!and_later) return wiring;
  // The linuxcnc script runs every HALCMD after the HALFILEs ("halcmd $HALCMD": no INI given,
  // so no [SECTION]KEY is replaced), then the GUI runs POSTGUI_HALFILE.
  for (const auto& c : ini.get_all("HAL", "HALCMD")) {
    std::vector<std::string> words;
    std::istringstream in(c.value);
    for (std::string word; in >> word;) words.push_back(word);
    if (!words.empty()) hal_command(wiring, words, {c.file, c.line, true});
  }
  read_hal_files(ini, ini.get_all("HAL", "POSTGUI_HALFILE"), skip, wiring);
  return wiring;
}

}  // namespace circtest::compensation
