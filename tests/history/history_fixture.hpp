#pragma once
// The fixture of the history tests (test_history*.cpp, one executable): the same tests
// against an SQLite file and a PostgreSQL server (the ctest fixture's, or one started here).
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <pwd.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <regex>
#include <sstream>

#include "circtest/analysis/report.hpp"
#include "circtest/analysis/uncertainty.hpp"
#include "circtest/circana/history_record.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/sha256.hpp"
#include "circtest/history/history.hpp"
#include "expect_error.hpp"
#include "machine_sim.hpp"
#include "scratch.hpp"

namespace fs = std::filesystem;

namespace circtest_history_test {

using namespace circtest;
using namespace circtest::history;

// A file that is not there reads as "" (the checks below then say what is missing).
inline std::string slurp(const fs::path& p) {
  return circtest::testing::slurp_if_exists(p);
}

struct Result {
  int code = -1;
  std::string out, err;
};

inline Result run(const std::string& cmd, const fs::path& dir) {
  const fs::path out = dir / "stdout", err = dir / "stderr";
  const int status = std::system((cmd + " >" + out.string() + " 2>" + err.string()).c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(out), slurp(err)};
}

// A PostgreSQL server of its own in a temporary folder, reachable only by its Unix socket.
class PostgresServer {
 public:
  PostgresServer() {
    static int servers = 0;
    const int n = servers++;
    dir_ = fs::temp_directory_path() / fmt::format("circtest-pg-{}-{}", getpid(), n);
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    bin_ = find_bin();
    // initdb refuses to run as root: the server runs as nobody then.
    if (geteuid() == 0) {
      const passwd* pw = getpwnam("nobody");
      if (!pw || chown(dir_.c_str(), pw->pw_uid, pw->pw_gid) != 0) {
        throw std::runtime_error("cannot hand " + dir_.string() + " to nobody");
      }
      as_ = "runuser -u nobody -- ";
    }
    port_ = 20000 + static_cast<int>((getpid() * 2 + n) % 20000);
    sh(fmt::format("{}'{}/initdb' -D '{}/data' -A trust -U circtest --no-sync -E UTF8", as_, bin_,
                   dir_.string()));
    start();
  }
  // The server of the ctest fixture history_pg (pg-server.sh), shared by every db test
  // process: neither stopped nor removed here.
  PostgresServer(fs::path dir, int port) : dir_(std::move(dir)), port_(port), owned_(false) {}
  // The fixture's server when ctest started one (CIRCTEST_PG_SHARED_DIR/server), else null.
  static std::unique_ptr<PostgresServer> shared() {
    std::ifstream in(fs::path(CIRCTEST_PG_SHARED_DIR) / "server");
    std::string dir;
    int port = 0;
    if (!(in >> dir >> port)) return nullptr;
    return std::make_unique<PostgresServer>(dir, port);
  }
  bool owned() const { return owned_; }
  ~PostgresServer() {
    if (!owned_) return;
    stop();
    fs::remove_all(dir_);
  }
  void start() {
    sh(
        fmt::format("{}'{}/pg_ctl' -D '{}/data' -l '{}/log' -w -o \"-k {} -p {} -c "
                    "listen_addresses='' -c fsync=off\" start",
                    as_, bin_, dir_.string(), dir_.string(), dir_.string(), port_));
  }
  void stop() {
    std::system(fmt::format("{}'{}/pg_ctl' -D '{}/data' -m fast -w stop >/dev/null 2>&1", as_, bin_,
                            dir_.string())
                    .c_str());
  }
  // Stops at once, as a crash would: open transactions are lost, never half-applied.
  void kill() {
    std::system(fmt::format("{}'{}/pg_ctl' -D '{}/data' -m immediate -w stop >/dev/null 2>&1", as_,
                            bin_, dir_.string())
                    .c_str());
  }
  std::string url(const std::string& db = "postgres") const {
    return fmt::format("postgresql:///{}?host={}&port={}&user=circtest", db, dir_.string(), port_);
  }
  void create_database(const std::string& name) {
    sh(fmt::format("psql -q -h '{}' -p {} -U circtest -d postgres -c 'CREATE DATABASE {}'",
                   dir_.string(), port_, name));
  }

 private:
  static std::string find_bin() {
    for (const auto& e : fs::directory_iterator("/usr/lib/postgresql")) {
      if (fs::exists(e.path() / "bin/initdb")) return (e.path() / "bin").string();
    }
    throw std::runtime_error(
        "PostgreSQL is not installed (the postgresql package of scripts/debian-packages-test.txt)");
  }
  void sh(const std::string& cmd) {
    const std::string full = cmd + " >>'" + (dir_ / "setup.log").string() + "' 2>&1";
    if (std::system(full.c_str()) != 0) {
      throw std::runtime_error("failed: " + cmd + "\n" + slurp(dir_ / "setup.log"));
    }
  }
  fs::path dir_;
  std::string bin_, as_;
  int port_ = 0;
  bool owned_ = true;
};

inline PostgresServer* g_server = nullptr;
inline int g_databases = 0;

// The record of an evaluation document, read back as circana store reads it.
inline TestRecord record_from_result(const nlohmann::json& document, std::nullptr_t,
                                     const std::string& machine = {}) {
  return history_record(evaluation_from_json(nlohmann::ordered_json::parse(document.dump())),
                        nullptr, machine);
}

// The evaluation document of a simulated test with a known backlash (H = backlash).
inline nlohmann::json simulated_result(double backlash_mm, const std::string& date,
                                       const fs::path& dir) {
  sim::MachineModel m;
  m.x.backlash_mm = backlash_mm;
  sim::CircleProgram p;
  p.period_s = 0.004;
  Trace t = sim::simulate(m, p);
  t.metadata.set("machine", "VMC-3");
  t.metadata.set("date", date);
  t.metadata.set("operator", "A. Sato");
  const fs::path path = dir / fmt::format("trace-{}.csv", date);
  write_trace(path.string(), t);
  const Trace back = read_trace(path.string());
  return nlohmann::json::parse(to_json(evaluate(back, {})).dump());
}

enum class Backend { sqlite, postgresql };

class History : public ::testing::TestWithParam<Backend> {
 protected:
  static void SetUpTestSuite() {
    if (!g_server) {
      auto shared = PostgresServer::shared();
      g_server = shared ? shared.release() : new PostgresServer();
    }
  }
  static void TearDownTestSuite() {
    delete g_server;
    g_server = nullptr;
  }
  void SetUp() override {
    std::string test = ::testing::UnitTest::GetInstance()->current_test_info()->name();
    std::replace(test.begin(), test.end(), '/', '-');
    dir_ = fs::temp_directory_path() / fmt::format("circtest-history-{}-{}", getpid(), test);
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    if (GetParam() == Backend::sqlite) {
      url_ = (dir_ / "history.sqlite").string();
    } else {
      // A fresh database per test: migration from nothing every time.
      // Named by process too: the fixture's server is shared by every test process.
      const std::string db = fmt::format("t{}_{}", getpid(), ++g_databases);
      g_server->create_database(db);
      url_ = g_server->url(db);
    }
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string circana(const std::string& args) const {
    return std::string(CIRCANA_PATH) + " " + args + " --db '" + url_ + "'";
  }

  fs::path dir_;
  std::string url_;
};

inline std::string name(const ::testing::TestParamInfo<Backend>& info) {
  return info.param == Backend::sqlite ? "SQLite" : "PostgreSQL";
}

}  // namespace circtest_history_test
