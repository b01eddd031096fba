// The embedded history: one SQLite file, WAL so that readers never block the writer, and a
// busy timeout so that two machines storing at once queue instead of failing.
#include <sqlite3.h>

#include <fmt/format.h>
#include <filesystem>

#include "circtest/core/error.hpp"
#include "connection.hpp"

namespace circtest::history::detail {

namespace {

constexpr int kBusyTimeoutMs = 60000;

class SqliteConnection final : public Connection {
 public:
  SqliteConnection(const std::string& path, std::string_view setting)
      : name_(path), setting_(setting) {
    std::error_code ec;
    const auto parent = std::filesystem::path(path).parent_path();
    if (!parent.empty()) std::filesystem::create_directories(parent, ec);
    if (std::filesystem::exists(path, ec) && !std::filesystem::is_regular_file(path, ec)) {
      throw DatabaseError(path + ": not a regular file");
    }
    const int rc =
        sqlite3_open_v2(path.c_str(), &db_, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, nullptr);
    if (rc != SQLITE_OK) {
      const std::string m = db_ ? sqlite3_errmsg(db_) : sqlite3_errstr(rc);
      sqlite3_close(db_);
      db_ = nullptr;
      throw DatabaseError(fmt::format("{}: cannot open the history database: {}", path, m));
    }
    sqlite3_extended_result_codes(db_, 1);
    sqlite3_busy_timeout(db_, kBusyTimeoutMs);
    try {
      const auto mode = query("PRAGMA journal_mode=WAL", {});
      if (mode.empty() || !mode[0][0] || *mode[0][0] != "wal") {
        throw DatabaseError(path + ": cannot switch the history database to WAL mode");
      }
      query("PRAGMA foreign_keys=ON", {});
    } catch (...) {
      sqlite3_close(db_);
      db_ = nullptr;
      throw;
    }
  }
  ~SqliteConnection() override {
    if (db_) sqlite3_close(db_);
  }

  std::vector<Row> query(const std::string& sql, const std::vector<Value>& params) override {
    sqlite3_stmt* st = nullptr;
    if (sqlite3_prepare_v2(db_, sql.c_str(), static_cast<int>(sql.size()), &st, nullptr) !=
        SQLITE_OK) {
      fail("");
    }
    struct Finalize {
      sqlite3_stmt* s;
      ~Finalize() { sqlite3_finalize(s); }
    } guard{st};
    for (std::size_t i = 0; i < params.size(); ++i) {
      const int k = static_cast<int>(i + 1);
      const int rc = params[i]
                         ? sqlite3_bind_text(st, k, params[i]->c_str(),
                                             static_cast<int>(params[i]->size()), SQLITE_TRANSIENT)
                         : sqlite3_bind_null(st, k);
      if (rc != SQLITE_OK) fail("");
    }
    std::vector<Row> rows;
    while (true) {
      const int rc = sqlite3_step(st);
      if (rc == SQLITE_DONE) break;
      if (rc != SQLITE_ROW) fail("");
      Row row;
      const int n = sqlite3_column_count(st);
      for (int c = 0; c < n; ++c) {
        if (sqlite3_column_type(st, c) == SQLITE_NULL) {
          row.emplace_back(std::nullopt);
        } else {
          const auto* text = reinterpret_cast<const char*>(sqlite3_column_text(st, c));
          row.emplace_back(
              std::string(text, static_cast<std::size_t>(sqlite3_column_bytes(st, c))));
        }
      }
      rows.push_back(std::move(row));
    }
    return rows;
  }
  void begin_write() override { query("BEGIN IMMEDIATE", {}); }
  void lock_schema() override {}  // BEGIN IMMEDIATE already holds the only write lock
  void commit() override { query("COMMIT", {}); }
  void rollback() noexcept override {
    if (!sqlite3_get_autocommit(db_)) sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
  }
  const char* id_column() const override { return "INTEGER PRIMARY KEY AUTOINCREMENT"; }
  const std::string& name() const override { return name_; }

 private:
  [[noreturn]] void fail(const char*) {
    const int code = sqlite3_errcode(db_) & 0xff;
    const std::string m = sqlite3_errmsg(db_);
    if (code == SQLITE_NOTADB || code == SQLITE_CORRUPT) {
      throw DatabaseError(fmt::format(
          "{}: not a usable SQLite history database ({}): move it away or give another {}", name_,
          m, setting_));
    }
    throw DatabaseError(fmt::format("{}: {}", name_, m));
  }

  std::string name_;
  std::string setting_;  // how the caller names the database setting
  sqlite3* db_ = nullptr;
};

}  // namespace

std::unique_ptr<Connection> open_sqlite(const std::string& path, std::string_view setting) {
  return std::make_unique<SqliteConnection>(path, setting);
}

}  // namespace circtest::history::detail
