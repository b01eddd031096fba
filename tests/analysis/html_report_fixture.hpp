#pragma once
// The fixture of the circana report tests in real headless Chromium (test_html_report*.cpp):
// circana and circtest-simtrace run on scratch files, the report opened, printed and measured.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "circtest/core/strings.hpp"
#include "scratch.hpp"

namespace fs = std::filesystem;

namespace circtest_html_report_test {

using circtest::testing::CommandResult;
using circtest::testing::run_command;
using circtest::testing::slurp;

using circtest::testing::words;

inline std::string mm(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.12g", v);
  return buf;
}

inline std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (auto p = text.find(what); p != std::string::npos; p = text.find(what, p + 1)) ++n;
  return n;
}

// Measures the right edge of the widest element and writes it, and which element it is, into
// two attributes of <body>.
inline constexpr const char* kWidthProbe =
    "<script>let w = document.documentElement.scrollWidth, who = 'html';"
    "for (const e of document.querySelectorAll('*')) {"
    "  const r = e.getBoundingClientRect();"
    "  if (r.right > w) { w = r.right; who = e.tagName + ' ' + e.getAttribute('class'); }"
    "}"
    "document.body.setAttribute('data-widest', Math.ceil(w));"
    "document.body.setAttribute('data-widest-element', who);</script>";

class HtmlReport : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!fs::exists(CHROMIUM_PATH)) {
      GTEST_SKIP() << "chromium not installed (Debian package chromium): the HTML report is "
                      "not checked";
    }
  }

  CommandResult circana(const std::vector<std::string>& args) {
    std::vector<std::string> argv{CIRCANA_PATH};
    argv.insert(argv.end(), args.begin(), args.end());
    return run_command(argv);
  }
  CommandResult circana(const std::string& args) { return circana(words(args)); }

  std::string simtrace(const std::string& name, const std::string& args) {
    const std::string path = (dir_ / name).string();
    std::vector<std::string> argv{SIMTRACE_PATH, "-o", path};
    for (auto& w : words(args)) argv.push_back(std::move(w));
    const CommandResult r = run_command(argv);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return path;
  }

  // Chromium, headless, with its own profile (parallel tests do not share one) and logging of
  // the page's console on stderr.
  CommandResult chromium(const std::vector<std::string>& args) {
    std::vector<std::string> argv{CHROMIUM_PATH,
                                  "--headless",
                                  "--disable-gpu",
                                  "--no-first-run",
                                  "--user-data-dir=" + (dir_ / "profile").string(),
                                  "--enable-logging=stderr",
                                  "--v=0"};
    // The sandbox needs user namespaces Chromium refuses to use as root.
    if (geteuid() == 0) argv.push_back("--no-sandbox");
    argv.insert(argv.end(), args.begin(), args.end());
    return run_command(argv);
  }
  // A report as one Chromium run sees it, laid out in a window as wide as A4 portrait at 96
  // dpi (794 px): its DOM, the right edge in CSS px of its widest element, and, when asked,
  // its printed pages and a screenshot of the window.
  struct Opened {
    std::string dom;
    double widest_px = 1e9;
    std::string widest;  // that element: tag and class
    int pages = -1;      // of the printed PDF
  };
  // One Chromium start does it all (each start costs seconds of CPU): it opens a copy of the
  // report with a measuring script before </body>, dumps the DOM, prints and takes the
  // screenshot. The script adds nothing but two attributes of <body>; both and the script are
  // taken out of the DOM handed back, which is then the report's own.
  Opened open(const std::string& html, const std::string& pdf = {}, const std::string& png = {}) {
    std::string text = slurp(html);
    const auto body = text.rfind("</body>");
    EXPECT_NE(body, std::string::npos);
    if (body == std::string::npos) return {};
    text.insert(body, kWidthProbe);
    const std::string probe = (dir_ / "probe.html").string();
    circtest::testing::spit(probe, text);
    std::vector<std::string> args{"--window-size=794,1123", "--dump-dom"};
    if (!pdf.empty()) args.insert(args.end(), {"--no-pdf-header-footer", "--print-to-pdf=" + pdf});
    if (!png.empty()) args.push_back("--screenshot=" + png);
    args.push_back("file://" + probe);
    const CommandResult r = chromium(args);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    console_ = r.err;
    Opened page;
    page.dom = r.out;
    std::smatch m;
    static const std::regex widest(R"re( data-widest="(\d+)" data-widest-element="([^"]*)")re");
    const auto script = page.dom.find(kWidthProbe);
    if (!std::regex_search(page.dom, m, widest) || script == std::string::npos) {
      ADD_FAILURE() << "the width probe did not run";
      return page;
    }
    page.widest_px = std::stod(m[1]);
    page.widest = m[2];
    const auto attributes = static_cast<std::size_t>(m.position(0));
    const auto attributes_size = static_cast<std::size_t>(m.length(0));
    EXPECT_LT(attributes, script) << "the probe's attributes are those of <body>";
    page.dom.erase(script, std::string(kWidthProbe).size());
    page.dom.erase(attributes, attributes_size);
    if (!pdf.empty()) page.pages = pdf_pages(pdf);
    return page;
  }
  // The pages of the printed PDF (A4 each): pdfinfo when installed, else the /Type /Page
  // objects.
  int pdf_pages(const std::string& pdf) {
    if (fs::exists(PDFINFO_PATH)) {
      const CommandResult info = run_command({PDFINFO_PATH, pdf});
      EXPECT_EQ(info.exit_code, 0) << info.err;
      std::smatch m;
      static const std::regex a4(R"(Page size:\s+(\d+(\.\d+)?) x (\d+(\.\d+)?) pts)");
      EXPECT_TRUE(std::regex_search(info.out, m, a4)) << info.out;
      if (!m.empty()) {
        EXPECT_NEAR(std::stod(m[1]), 595.0, 2.0) << "A4 width";
        EXPECT_NEAR(std::stod(m[3]), 842.0, 2.0) << "A4 height";
      }
      static const std::regex pages(R"(Pages:\s+(\d+))");
      if (std::regex_search(info.out, m, pages)) return std::stoi(m[1]);
      ADD_FAILURE() << "pdfinfo: no page count\n" << info.out;
      return -1;
    }
    const std::string bytes = slurp(pdf);
    static const std::regex page(R"(/Type\s*/Page\b)");
    return static_cast<int>(
        std::distance(std::sregex_iterator(bytes.begin(), bytes.end(), page), {}));
  }
  // The text of page K of the PDF (pdftotext).
  std::string pdf_page_text(const std::string& pdf, int k) {
    if (!fs::exists(PDFTOTEXT_PATH)) {
      ADD_FAILURE() << "pdftotext (poppler-utils) is needed to read the printed pages";
      return {};
    }
    const std::string n = std::to_string(k);
    const CommandResult r = run_command({PDFTOTEXT_PATH, "-f", n, "-l", n, pdf, "-"});
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return r.out;
  }
  // The page's console lines in Chromium's log (errors, warnings, logs alike).
  std::string console_messages() const {
    std::string out;
    std::istringstream in(console_);
    for (std::string line; std::getline(in, line);) {
      if (line.find(":CONSOLE") != std::string::npos) out += line + "\n";
    }
    return out;
  }

  circtest::testing::ScratchDir scratch_{"circana-report"};
  fs::path dir_ = scratch_.dir();
  std::string console_;
};

}  // namespace circtest_html_report_test
