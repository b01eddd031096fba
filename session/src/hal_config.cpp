#include "circtest/session/hal_config.hpp"

#include <filesystem>
#include <regex>
#include <sstream>

#include "circtest/core/atomic_file.hpp"
#include "circtest/core/strings.hpp"
#include "session_steps.hpp"

namespace circtest::session {

std::vector<std::string> words_of(const std::string& line) {
  std::vector<std::string> words;
  std::istringstream in(line);
  for (std::string w; in >> w;) words.push_back(w);
  return words;
}

namespace {

bool is_input_side(const std::string& pin) {
  return pin.rfind("joint.", 0) == 0 || pin.find(".feedback") != std::string::npos ||
         pin.find(".command") != std::string::npos || pin.rfind("circlog.", 0) == 0;
}

void add_pin(HalWiring& wiring, const std::string& signal, const std::string& pin, bool writer,
             const HalPlace& place) {
  wiring.signals[signal].push_back({pin, writer, place});
  wiring.signal_of_pin.emplace(pin, signal);
}

// `net SIGNAL PIN [=>|<=|<=>] PIN ...`: a pin before "=>" or right after "<=" writes it.
void read_net(const std::vector<std::string>& w, const HalPlace& place, HalWiring& wiring) {
  const std::string& signal = w[1];
  wiring.signals[signal];
  bool after_out_arrow = false;
  for (std::size_t i = 2; i < w.size(); ++i) {
    if (w[i] == "=>" || w[i] == "<=" || w[i] == "<=>") continue;
    const bool before_right = i + 1 < w.size() && w[i + 1] == "=>";
    const bool after_left = i > 2 && w[i - 1] == "<=";
    add_pin(wiring, signal, w[i], (before_right || after_left) && !after_out_arrow, place);
    if (before_right) after_out_arrow = true;
  }
}

}  // namespace

std::optional<std::string> HalWiring::source_of(const std::string& signal) const {
  const auto it = signals.find(signal);
  if (it == signals.end()) return std::nullopt;
  for (const auto& p : it->second) {
    if (p.writer) return p.pin;
  }
  for (const auto& p : it->second) {
    if (!is_input_side(p.pin)) return p.pin;
  }
  return std::nullopt;
}

std::string substitute_ini_values(const std::string& line, const IniDocument& ini) {
  static const std::regex ref(R"(\[([A-Za-z0-9_]+)\]([A-Za-z0-9_]+))");
  std::string out;
  auto begin = std::sregex_iterator(line.begin(), line.end(), ref);
  std::size_t last = 0;
  for (auto it = begin; it != std::sregex_iterator(); ++it) {
    const auto& m = *it;
    out += line.substr(last, static_cast<std::size_t>(m.position()) - last);
    const auto value = ini.get(m[1].str(), m[2].str());
    out += value ? *value : m.str();
    last = static_cast<std::size_t>(m.position() + m.length());
  }
  return out + line.substr(last);
}

void read_hal_text(const std::string& text, const std::string& source, const IniDocument& ini,
                   HalWiring& wiring) {
  std::istringstream in(text);
  std::size_t number = 0;
  std::string joined;
  for (std::string line; std::getline(in, line);) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (!line.empty() && line.back() == '\\') {
      joined += line.substr(0, line.size() - 1) + " ";
      continue;
    }
    line = joined + line;
    joined.clear();
    if (const auto hash = line.find('#'); hash != std::string::npos) line.erase(hash);
    const auto w = words_of(substitute_ini_values(line, ini));
    if (w.empty()) continue;
    const HalPlace place{source, number};
    if (w[0] == "net" && w.size() >= 2) {
      read_net(w, place, wiring);
    } else if (w[0] == "linksp" && w.size() >= 3) {
      add_pin(wiring, w[1], w[2], false, place);
    } else if (w[0] == "linkps" && w.size() >= 3) {
      add_pin(wiring, w[2], w[1], false, place);
    } else if (w[0] == "loadrt" && w.size() >= 2) {
      wiring.loaded.emplace(w[1], place);
      wiring.load_args.emplace(w[1], std::vector<std::string>(w.begin() + 2, w.end()));
    } else if (w[0] == "addf" && w.size() >= 3) {
      wiring.thread_of_function.emplace(w[1], w[2]);
    }
  }
}

HalWiring read_hal_wiring(const IniDocument& ini, const std::string& config_dir) {
  HalWiring wiring;
  for (const auto& entry : ini.get_all("HAL", "HALFILE")) {
    // "FILE ARG..." : the file is the first word (the linuxcnc script passes the rest on).
    const std::string name = words_of(entry.value).empty() ? "" : words_of(entry.value)[0];
    const std::filesystem::path path = std::filesystem::path(config_dir) / name;
    const bool tcl = name.size() > 4 && name.substr(name.size() - 4) == ".tcl";
    std::error_code ec;
    if (tcl || name.rfind("LIB:", 0) == 0 || !std::filesystem::is_regular_file(path, ec)) {
      wiring.files_not_read.push_back(name);
      continue;
    }
    read_hal_text(read_file(path.string()), name, ini, wiring);
    wiring.files_read.push_back(name);
  }
  return wiring;
}

}  // namespace circtest::session
