#pragma once
// The little a store needs from a database: statements with `?` parameters, rows of text,
// transactions. SQLite and PostgreSQL implement it; the schema, migrations and queries are
// written once over it (store.cpp).
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace circtest::history::detail {

using Value = std::optional<std::string>;  // NULL or the value as text
using Row = std::vector<Value>;

class Connection {
 public:
  virtual ~Connection() = default;
  // Runs one statement; `?` marks parameters. Returns the rows it yields.
  virtual std::vector<Row> query(const std::string& sql, const std::vector<Value>& params = {}) = 0;
  // Starts a transaction that holds the write lock from the start (SQLite: BEGIN IMMEDIATE),
  // so that two writers queue instead of failing when one upgrades its lock.
  virtual void begin_write() = 0;
  // Serialises schema migrations between processes inside the open transaction.
  virtual void lock_schema() = 0;
  virtual void commit() = 0;
  virtual void rollback() noexcept = 0;
  // The SQL type of the auto-numbered primary key column.
  virtual const char* id_column() const = 0;
  virtual const std::string& name() const = 0;
};

// `setting`: how the front end names the database setting, for its messages.
std::unique_ptr<Connection> open_sqlite(const std::string& path, std::string_view setting);
std::unique_ptr<Connection> open_postgresql(const std::string& url);

}  // namespace circtest::history::detail
