// The schema, its migrations and the queries, written once over detail::Connection.

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "circtest/core/error.hpp"
#include "circtest/core/json_text.hpp"
#include "circtest/core/numbers.hpp"
#include "circtest/core/strings.hpp"
#include "circtest/core/utc_time.hpp"
#include "circtest/history/history.hpp"
#include "connection.hpp"

namespace circtest::history {

using detail::Connection;
using detail::Row;
using detail::Value;
using json = nlohmann::json;

namespace {

// Migration N (1-based) brings the schema from version N-1 to N. Append, never edit: a
// database records the versions it has applied. {id} is the backend's auto-numbered key.
const std::vector<std::vector<std::string>>& migrations() {
  static const std::vector<std::vector<std::string>> m = {
      {
          "CREATE TABLE tests (id {id}, machine TEXT NOT NULL, tested_at TEXT NOT NULL, "
          "stored_at TEXT NOT NULL, plane TEXT NOT NULL, channels TEXT NOT NULL, "
          "trace_path TEXT NOT NULL, trace_sha256 TEXT, h_mm DOUBLE PRECISION, "
          "g_mm DOUBLE PRECISION, f_mm DOUBLE PRECISION, backlash_mm DOUBLE PRECISION, "
          "squareness_urad DOUBLE PRECISION, conditions TEXT NOT NULL, result TEXT NOT NULL, "
          "diagnosis TEXT)",
          "CREATE INDEX tests_machine_time ON tests (machine, tested_at)",
          "CREATE TABLE measures (test_id BIGINT NOT NULL REFERENCES tests (id) ON DELETE "
          "CASCADE, seq INTEGER NOT NULL, kind TEXT NOT NULL, label TEXT NOT NULL, "
          "direction TEXT NOT NULL, feed_mm_per_min DOUBLE PRECISION, "
          "value_mm DOUBLE PRECISION NOT NULL, PRIMARY KEY (test_id, seq))",
      },
      // The expanded uncertainty (k = 2) of H, G and F: NULL in the tests stored before.
      {
          "ALTER TABLE tests ADD COLUMN u_h_mm DOUBLE PRECISION",
          "ALTER TABLE tests ADD COLUMN u_g_mm DOUBLE PRECISION",
          "ALTER TABLE tests ADD COLUMN u_f_mm DOUBLE PRECISION",
          "ALTER TABLE measures ADD COLUMN u_mm DOUBLE PRECISION",
      },
  };
  return m;
}

Value number(const std::optional<double>& v) {
  return v ? Value(fmt::format("{:.17g}", *v)) : Value();
}

// What a record must be to be stored: its text UTF-8 (a PostgreSQL database refuses
// anything else, and every output of the history is JSON, XML or text), every number
// finite. DataError naming the field otherwise: nothing is written.
void check_record(const TestRecord& r) {
  auto text = [](const std::string& value, const char* field) {
    if (const std::size_t bad = invalid_utf8_offset(value); bad != std::string::npos) {
      throw Error(ExitCode::data,
                  fmt::format("history record: {} is not UTF-8 text (byte {} of '{}')", field,
                              bad + 1, utf8_replacing_invalid(value)));
    }
  };
  text(r.machine, "machine");
  text(r.tested_at, "tested_at");
  text(r.plane, "plane");
  text(r.channels, "channels");
  text(r.trace_path, "trace_path");
  if (!r.tested_at.empty() && !canonical_utc_iso8601(r.tested_at)) {
    throw Error(ExitCode::data, fmt::format("history record: tested_at '{}' is not an ISO 8601 "
                                            "date or date-time",
                                            utf8_replacing_invalid(r.tested_at)));
  }
  for (const Measure& m : r.measures) {
    text(m.kind, "a measure's kind");
    text(m.label, "a measure's label");
    text(m.direction, "a measure's direction");
  }
  for_each_number(r, [](const std::optional<double>& v, const std::string& field) {
    if (v && !std::isfinite(*v)) {
      throw Error(ExitCode::data,
                  fmt::format("history record: {} = {} is not a finite number", field, *v));
    }
  });
}

// Rolls back unless committed: a store is all or nothing, whatever throws.
class Transaction {
 public:
  explicit Transaction(Connection& c) : c_(c) { c_.begin_write(); }
  ~Transaction() {
    if (!done_) c_.rollback();
  }
  void commit() {
    c_.commit();
    done_ = true;
  }

 private:
  Connection& c_;
  bool done_ = false;
};

class SqlStore final : public Store {
 public:
  explicit SqlStore(std::unique_ptr<Connection> c) : c_(std::move(c)) { migrate(); }

  std::int64_t add(const TestRecord& r) override {
    check_record(r);
    Transaction tx(*c_);
    const std::string now = utc_now_iso8601();
    const auto rows = c_->query(
        "INSERT INTO tests (machine, tested_at, stored_at, plane, channels, trace_path, "
        "trace_sha256, h_mm, g_mm, f_mm, backlash_mm, squareness_urad, conditions, result, "
        "diagnosis, u_h_mm, u_g_mm, u_f_mm) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, "
        "?, ?, ?) RETURNING id",
        {r.machine, r.tested_at.empty() ? now : r.tested_at,
         r.stored_at.empty() ? now : r.stored_at, r.plane, r.channels, r.trace_path,
         r.trace_sha256.empty() ? Value() : Value(r.trace_sha256), number(r.h_mm), number(r.g_mm),
         number(r.f_mm), number(r.backlash_mm), number(r.squareness_urad), json_text(r.conditions),
         json_text(r.result), r.diagnosis.is_null() ? Value() : Value(json_text(r.diagnosis)),
         number(r.u_h_mm), number(r.u_g_mm), number(r.u_f_mm)});
    if (rows.size() != 1 || !rows[0][0]) {
      throw DatabaseError(c_->name() + ": the new test got no id");
    }
    const std::int64_t id = std::stoll(*rows[0][0]);
    for (std::size_t i = 0; i < r.measures.size(); ++i) {
      const Measure& m = r.measures[i];
      c_->query(
          "INSERT INTO measures (test_id, seq, kind, label, direction, feed_mm_per_min, "
          "value_mm, u_mm) VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
          {std::to_string(id), std::to_string(i), m.kind, m.label, m.direction,
           number(m.feed_mm_per_min), number(m.value_mm), number(m.u_mm)});
    }
    tx.commit();
    return id;
  }

  std::vector<TestRecord> tests(const std::string& machine, const std::string& since) override {
    const auto rows = c_->query(
        "SELECT id, machine, tested_at, stored_at, plane, channels, trace_path, trace_sha256, "
        "h_mm, g_mm, f_mm, backlash_mm, squareness_urad, conditions, result, diagnosis, "
        "u_h_mm, u_g_mm, u_f_mm FROM tests WHERE machine = ? AND tested_at >= ? ORDER BY "
        "tested_at, id",
        {machine, since});
    std::vector<TestRecord> out;
    for (const Row& row : rows) {
      TestRecord r;
      r.id = std::stoll(row[0].value_or("0"));
      r.machine = row[1].value_or("");
      r.tested_at = row[2].value_or("");
      r.stored_at = row[3].value_or("");
      r.plane = row[4].value_or("");
      r.channels = row[5].value_or("");
      r.trace_path = row[6].value_or("");
      r.trace_sha256 = row[7].value_or("");
      r.h_mm = stored_number(row[8], r.id);
      r.g_mm = stored_number(row[9], r.id);
      r.f_mm = stored_number(row[10], r.id);
      r.backlash_mm = stored_number(row[11], r.id);
      r.squareness_urad = stored_number(row[12], r.id);
      r.conditions = parse(row[13], r.id);
      r.result = parse(row[14], r.id);
      r.diagnosis = row[15] ? parse(row[15], r.id) : json(nullptr);
      r.u_h_mm = stored_number(row[16], r.id);
      r.u_g_mm = stored_number(row[17], r.id);
      r.u_f_mm = stored_number(row[18], r.id);
      out.push_back(std::move(r));
    }
    const auto mrows = c_->query(
        "SELECT m.test_id, m.kind, m.label, m.direction, m.feed_mm_per_min, m.value_mm, m.u_mm "
        "FROM measures m JOIN tests t ON t.id = m.test_id "
        "WHERE t.machine = ? AND t.tested_at >= ? ORDER BY m.test_id, m.seq",
        {machine, since});
    for (const Row& row : mrows) {
      const std::int64_t id = std::stoll(row[0].value_or("0"));
      auto it = std::find_if(out.begin(), out.end(), [id](const auto& t) { return t.id == id; });
      if (it == out.end()) continue;  // stored between the two queries
      const std::optional<double> value = stored_number(row[5], id);
      if (!value)
        throw DatabaseError(
            fmt::format("{}: test {} holds a measure without a value", c_->name(), id));
      it->measures.push_back({row[1].value_or(""), row[2].value_or(""), row[3].value_or(""),
                              stored_number(row[4], id), *value, stored_number(row[6], id)});
    }
    return out;
  }

  std::vector<std::string> machines() override {
    std::vector<std::string> out;
    for (const Row& row : c_->query("SELECT DISTINCT machine FROM tests ORDER BY machine")) {
      out.push_back(row[0].value_or(""));
    }
    return out;
  }

  int schema_version() override {
    const auto rows = c_->query("SELECT MAX(version) FROM circtest_schema");
    return rows.empty() || !rows[0][0] ? 0 : std::stoi(*rows[0][0]);
  }

  const std::string& name() const override { return c_->name(); }

 private:
  json parse(const Value& v, std::int64_t id) const {
    try {
      return parse_json_text(v.value_or("null"), c_->name());
    } catch (const ParseError& e) {
      throw DatabaseError(
          fmt::format("{}: test {} holds a broken JSON document ({})", c_->name(), id, e.detail()));
    }
  }
  // A number column: NULL or a number. Text that is no number (written by another program)
  // is a DatabaseError rather than a zero in the trend; a non-finite one (stored before
  // add() refused them) is kept, and the outputs show it as "n/a".
  std::optional<double> stored_number(const Value& v, std::int64_t id) const {
    if (!v) return std::nullopt;
    const auto x = parse_number(*v);
    if (!x) {
      throw DatabaseError(fmt::format("{}: test {} holds '{}' where a number belongs", c_->name(),
                                      id, utf8_replacing_invalid(*v)));
    }
    return x;
  }

  // Creates the schema, or brings it up to date, in one transaction under a lock: two
  // processes opening a new database at once do not both migrate it.
  void migrate() {
    Transaction tx(*c_);
    c_->lock_schema();
    c_->query("CREATE TABLE IF NOT EXISTS circtest_schema (version INTEGER NOT NULL)");
    const int have = schema_version();
    const int latest = latest_schema_version();
    if (have > latest) {
      throw DatabaseError(fmt::format(
          "{}: the history has schema version {}, newer than this circtest knows ({}): use a "
          "newer circtest",
          c_->name(), have, latest));
    }
    for (int v = have; v < latest; ++v) {
      for (std::string sql : migrations()[static_cast<std::size_t>(v)]) {
        if (const auto p = sql.find("{id}"); p != std::string::npos) {
          sql.replace(p, 4, c_->id_column());
        }
        c_->query(sql);
      }
      c_->query("INSERT INTO circtest_schema (version) VALUES (?)", {std::to_string(v + 1)});
    }
    tx.commit();
  }

  std::unique_ptr<Connection> c_;
};

}  // namespace

int latest_schema_version() noexcept {
  return static_cast<int>(migrations().size());
}

std::string default_database_path(std::string_view setting) {
  std::string base;
  if (const char* x = std::getenv("XDG_DATA_HOME"); x && *x) {
    base = x;
  } else if (const char* h = std::getenv("HOME"); h && *h) {
    base = std::string(h) + "/.local/share";
  } else {
    throw UsageError(fmt::format(
        "{}: neither XDG_DATA_HOME nor HOME is set to find the default; give a path or URL",
        setting));
  }
  return base + "/circtest/history.sqlite";
}

std::unique_ptr<Store> open_store(const std::string& url, std::string_view setting) {
  if (url.rfind("postgresql://", 0) == 0 || url.rfind("postgres://", 0) == 0) {
    return std::make_unique<SqlStore>(detail::open_postgresql(url));
  }
  std::string path = url;
  if (path.rfind("sqlite:", 0) == 0) path = path.substr(7);
  if (path.empty()) path = default_database_path(setting);
  return std::make_unique<SqlStore>(detail::open_sqlite(path, setting));
}

}  // namespace circtest::history
