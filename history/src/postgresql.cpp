// The shop-wide history: a PostgreSQL server through libpq. Each store is one transaction;
// migrations are serialised by a transaction-scoped advisory lock.
#include <libpq-fe.h>

#include <fmt/format.h>

#include <regex>

#include "circtest/core/error.hpp"
#include "connection.hpp"

namespace circtest::history::detail {

namespace {

// An arbitrary constant: the advisory lock that serialises circtest's migrations.
constexpr long long kSchemaLockKey = 0x63697263746573;  // "circtes"

// The URL without its password, for messages.
std::string redact(const std::string& url) {
  return std::regex_replace(url, std::regex(R"(^([a-z]+://[^:/@]*):[^@]*@)"), "$1:***@");
}

std::string first_line(const char* text) {
  std::string s = text ? text : "";
  if (const auto nl = s.find('\n'); nl != std::string::npos) s.resize(nl);
  return s;
}

// "?" placeholders to "$1", "$2", ... (the SQL of store.cpp has no '?' in literals).
std::string numbered(const std::string& sql) {
  std::string out;
  int n = 0;
  for (char c : sql) {
    if (c == '?') {
      out += fmt::format("${}", ++n);
    } else {
      out += c;
    }
  }
  return out;
}

class PgConnection final : public Connection {
 public:
  explicit PgConnection(const std::string& url) : name_(redact(url)) {
    conn_ = PQconnectdb(url.c_str());
    if (!conn_ || PQstatus(conn_) != CONNECTION_OK) {
      const std::string m = conn_ ? first_line(PQerrorMessage(conn_)) : "out of memory";
      PQfinish(conn_);
      conn_ = nullptr;
      throw DatabaseError(fmt::format("{}: cannot connect to the history server: {}", name_, m));
    }
    query("SET client_min_messages = warning", {});  // no NOTICE for CREATE ... IF NOT EXISTS
  }
  ~PgConnection() override {
    if (conn_) PQfinish(conn_);
  }

  std::vector<Row> query(const std::string& sql, const std::vector<Value>& params) override {
    std::vector<const char*> values;
    for (const auto& p : params) values.push_back(p ? p->c_str() : nullptr);
    PGresult* r = PQexecParams(conn_, numbered(sql).c_str(), static_cast<int>(values.size()),
                               nullptr, values.data(), nullptr, nullptr, 0);
    struct Clear {
      PGresult* r;
      ~Clear() { PQclear(r); }
    } guard{r};
    const auto status = r ? PQresultStatus(r) : PGRES_FATAL_ERROR;
    if (status != PGRES_COMMAND_OK && status != PGRES_TUPLES_OK) {
      const std::string m = first_line(r ? PQresultErrorMessage(r) : PQerrorMessage(conn_));
      if (PQstatus(conn_) != CONNECTION_OK) {
        throw DatabaseError(
            fmt::format("{}: the connection to the history server was lost: {}", name_, m));
      }
      throw DatabaseError(fmt::format("{}: {}", name_, m));
    }
    std::vector<Row> rows;
    const int n = PQntuples(r), m = PQnfields(r);
    for (int i = 0; i < n; ++i) {
      Row row;
      for (int c = 0; c < m; ++c) {
        if (PQgetisnull(r, i, c)) {
          row.emplace_back(std::nullopt);
        } else {
          row.emplace_back(
              std::string(PQgetvalue(r, i, c), static_cast<std::size_t>(PQgetlength(r, i, c))));
        }
      }
      rows.push_back(std::move(row));
    }
    return rows;
  }
  void begin_write() override { query("BEGIN", {}); }
  void lock_schema() override {
    query(fmt::format("SELECT pg_advisory_xact_lock({})", kSchemaLockKey), {});
  }
  void commit() override { query("COMMIT", {}); }
  void rollback() noexcept override {
    if (conn_ && PQtransactionStatus(conn_) != PQTRANS_IDLE) {
      PQclear(PQexec(conn_, "ROLLBACK"));
    }
  }
  const char* id_column() const override { return "BIGSERIAL PRIMARY KEY"; }
  const std::string& name() const override { return name_; }

 private:
  std::string name_;
  PGconn* conn_ = nullptr;
};

}  // namespace

std::unique_ptr<Connection> open_postgresql(const std::string& url) {
  return std::make_unique<PgConnection>(url);
}

}  // namespace circtest::history::detail
