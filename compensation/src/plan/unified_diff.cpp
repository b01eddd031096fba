// circcomp's unified diff of a plan's files: an LCS table walk for configuration-sized files,
// Myers' greedy shortest edit script beyond (bounded memory for a large INI).
#include <fmt/format.h>

#include <algorithm>
#include <string>
#include <vector>

#include "circtest/compensation/plan.hpp"

namespace circtest::compensation {

namespace {

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> out;
  std::size_t b = 0;
  while (b < text.size()) {
    std::size_t e = text.find('\n', b);
    e = e == std::string::npos ? text.size() : e + 1;
    out.push_back(text.substr(b, e - b));
    b = e;
  }
  return out;
}

struct Op {
  char kind;  // ' ' kept, '-' removed, '+' added
  std::size_t ai, bi;
};

// The LCS table walk: for files up to kMaxLcsCells (configuration files are small), ties
// taking '-' first.
constexpr std::size_t kMaxLcsCells = std::size_t{4} << 20;
std::vector<Op> lcs_script(const std::vector<std::string>& a, const std::vector<std::string>& b) {
  const std::size_t n = a.size(), m = b.size();
  std::vector<std::vector<unsigned>> lcs(n + 1, std::vector<unsigned>(m + 1, 0));
  for (std::size_t i = n; i-- > 0;) {
    for (std::size_t j = m; j-- > 0;) {
      lcs[i][j] = a[i] == b[j] ? lcs[i + 1][j + 1] + 1 : std::max(lcs[i + 1][j], lcs[i][j + 1]);
    }
  }
  std::vector<Op> ops;
  std::size_t i = 0, j = 0;
  while (i < n || j < m) {
    if (i < n && j < m && a[i] == b[j])
      ops.push_back({' ', i++, j++});
    else if (j < m && (i == n || lcs[i][j + 1] > lcs[i + 1][j]))  // ties: '-' first
      ops.push_back({'+', i, j++});
    else
      ops.push_back({'-', i++, j});
  }
  return ops;
}

// Myers' greedy shortest edit script for larger files: time O((N + M) D), memory O(D^2) for
// D changed lines (a large INI with a few changes plans in bounded memory).
std::vector<Op> myers_script(const std::vector<std::string>& a, const std::vector<std::string>& b) {
  const long n = static_cast<long>(a.size()), m = static_cast<long>(b.size());
  std::vector<std::vector<long>> trace;  // V of every d: the furthest x on diagonal k
  std::vector<long> v(3, 0);             // diagonals -d-1 .. d+1 at offset d+1
  long d = 0;
  bool reached = false;
  for (;; ++d) {
    std::vector<long> next(2 * d + 3, 0);
    const auto at = [](std::vector<long>& row, long dd, long k) -> long& {
      return row[static_cast<std::size_t>(k + dd + 1)];
    };
    for (long k = -d; k <= d; k += 2) {
      long x = 0;
      if (d == 0) {
        x = 0;
      } else if (k == -d || (k != d && at(v, d - 1, k - 1) < at(v, d - 1, k + 1))) {
        x = at(v, d - 1, k + 1);  // down: an added line
      } else {
        x = at(v, d - 1, k - 1) + 1;  // right: a removed line
      }
      long y = x - k;
      while (x < n && y < m && a[static_cast<std::size_t>(x)] == b[static_cast<std::size_t>(y)]) {
        ++x;
        ++y;
      }
      at(next, d, k) = x;
      if (x >= n && y >= m) {
        reached = true;
        break;
      }
    }
    trace.push_back(next);
    if (reached) break;
    v = std::move(next);
  }
  std::vector<Op> ops;
  long x = n, y = m;
  for (long dd = d; dd > 0; --dd) {
    const std::vector<long>& prev = trace[static_cast<std::size_t>(dd - 1)];
    const auto prev_at = [&](long k) { return prev[static_cast<std::size_t>(k + dd)]; };
    const long k = x - y;
    const bool down = k == -dd || (k != dd && prev_at(k - 1) < prev_at(k + 1));
    const long pk = down ? k + 1 : k - 1;
    const long px = prev_at(pk), py = px - pk;
    while (x > (down ? px : px + 1) && y > (down ? py + 1 : py)) {
      --x;
      --y;
      ops.push_back({' ', static_cast<std::size_t>(x), static_cast<std::size_t>(y)});
    }
    if (down) {
      --y;
      ops.push_back({'+', static_cast<std::size_t>(x), static_cast<std::size_t>(y)});
    } else {
      --x;
      ops.push_back({'-', static_cast<std::size_t>(x), static_cast<std::size_t>(y)});
    }
  }
  while (x > 0 && y > 0) {
    --x;
    --y;
    ops.push_back({' ', static_cast<std::size_t>(x), static_cast<std::size_t>(y)});
  }
  std::reverse(ops.begin(), ops.end());
  return ops;
}

std::string file_diff(const FileChange& f) {
  const auto a = lines_of(f.before), b = lines_of(f.after);
  const std::vector<Op> ops =
      (a.size() + 1) * (b.size() + 1) <= kMaxLcsCells ? lcs_script(a, b) : myers_script(a, b);
  auto show = [](std::string line) {
    if (line.empty() || line.back() != '\n') return line + "\n\\ No newline at end of file\n";
    return line;
  };
  std::string out =
      fmt::format("--- {}\n+++ {}\n", f.existed ? "a/" + f.path : "/dev/null", "b/" + f.path);
  constexpr std::size_t kContext = 3;
  std::size_t k = 0;
  while (k < ops.size()) {
    if (ops[k].kind == ' ') {
      ++k;
      continue;
    }
    std::size_t start = k >= kContext ? k - kContext : 0;
    while (start < k && ops[start].kind != ' ') ++start;
    std::size_t end = k;
    std::size_t same = 0;
    while (end < ops.size() && same <= 2 * kContext) {
      same = ops[end].kind == ' ' ? same + 1 : 0;
      ++end;
    }
    end = std::min(ops.size(), end - (same > kContext ? same - kContext : 0));
    std::size_t a_count = 0, b_count = 0;
    for (std::size_t q = start; q < end; ++q) {
      a_count += ops[q].kind != '+';
      b_count += ops[q].kind != '-';
    }
    const std::size_t a_start = ops[start].ai + (a_count ? 1 : 0);
    const std::size_t b_start = ops[start].bi + (b_count ? 1 : 0);
    out += fmt::format("@@ -{},{} +{},{} @@\n", a_start, a_count, b_start, b_count);
    for (std::size_t q = start; q < end; ++q) {
      const Op& op = ops[q];
      out += op.kind;
      out += show(op.kind == '+' ? b[op.bi] : a[op.ai]);
    }
    k = end;
  }
  return out;
}

}  // namespace

std::string unified_diff(const Plan& plan) {
  std::string out;
  for (const FileChange& f : plan.files) out += file_diff(f);
  return out;
}

}  // namespace circtest::compensation
