// The history of a machine's tests in real databases: an SQLite file, and a PostgreSQL server
// started here (initdb + pg_ctl in a temporary folder, as an unprivileged user when run as
// root). The same tests run against both; nothing is mocked.
#include "history_fixture.hpp"

using namespace circtest_history_test;

TEST_P(History, MigratesAnEmptyDatabaseOnFirstUse) {
  if (GetParam() == Backend::sqlite) std::ofstream(url_).flush();  // an empty file
  const auto store = open_store(url_);
  EXPECT_EQ(store->schema_version(), latest_schema_version());
  EXPECT_TRUE(store->machines().empty());
  // Opening again finds it current and applies nothing twice.
  EXPECT_EQ(open_store(url_)->schema_version(), latest_schema_version());
}

TEST_P(History, StoresListsAndTrendsTestsOfAMachine) {
  const std::vector<std::pair<double, std::string>> tests = {
      {0.010, "2026-01-05"}, {0.015, "2026-03-02"}, {0.020, "2026-06-01"}};
  {
    const auto store = open_store(url_);
    for (const auto& [b, date] : tests) {
      TestRecord r = record_from_result(simulated_result(b, date, dir_), nullptr);
      r.trace_sha256 = sha256_of_file(r.trace_path);
      store->add(r);
    }
    // Another machine's test stays apart.
    store->add(record_from_result(simulated_result(0.005, "2026-02-01", dir_), nullptr, "HMC-1"));
  }
  const auto store = open_store(url_);
  EXPECT_EQ(store->machines(), (std::vector<std::string>{"HMC-1", "VMC-3"}));
  const auto all = store->tests("VMC-3", "");
  ASSERT_EQ(all.size(), 3u);
  for (std::size_t i = 0; i < all.size(); ++i) {
    const auto& t = all[i];
    EXPECT_EQ(t.tested_at, tests[i].second);  // oldest first
    // The simulator's only error is X backlash: H equals it.
    ASSERT_TRUE(t.h_mm);
    EXPECT_NEAR(*t.h_mm, tests[i].first, 0.0005);
    ASSERT_EQ(t.measures.size(), 7u);  // H, and G, F_max, F_min of two runs
    EXPECT_EQ(t.measures[0].kind, "H");
    EXPECT_EQ(t.measures[0].label, "XY");
    EXPECT_NEAR(t.measures[0].feed_mm_per_min.value_or(0), 1000.0, 5.0);
    EXPECT_EQ(t.measures[1].kind, "G");
    EXPECT_EQ(t.measures[1].direction, "CCW");
    EXPECT_EQ(t.conditions["operator"], "A. Sato");
    EXPECT_EQ(t.channels, "x,y");
    EXPECT_EQ(t.plane, "XY");
    EXPECT_EQ(t.result["runs"].size(), 2u);
    EXPECT_EQ(t.trace_sha256.size(), 64u);
    EXPECT_FALSE(t.backlash_mm);  // no diagnosis stored
  }
  EXPECT_EQ(store->tests("VMC-3", "2026-03-01").size(), 2u);
  EXPECT_EQ(store->tests("VMC-3", "2026-07-01").size(), 0u);

  // The CLI: the table, the JSON and the trend plot.
  Result r = run(circana("history --machine VMC-3 --since 2026-02-01 --json"), dir_);
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["schema"], "circtest.history/1");
  ASSERT_EQ(j["tests"].size(), 2u);
  EXPECT_NEAR(j["tests"][1]["H"].get<double>(), 0.020, 0.0005);
  r = run(circana("history --machine VMC-3 --svg " + (dir_ / "trend.svg").string()), dir_);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("History of machine VMC-3: 3 test(s)"), std::string::npos) << r.out;
  const std::string svg = slurp(dir_ / "trend.svg");
  std::size_t points = 0;
  for (auto p = svg.find("class=\"point\""); p != std::string::npos;
       p = svg.find("class=\"point\"", p + 1)) {
    ++points;
  }
  EXPECT_EQ(points, 9u);  // H, G, F of three tests; no backlash or squareness without diagnosis
  std::size_t u_bars = 0;
  for (auto p = svg.find("class=\"u-bar\""); p != std::string::npos;
       p = svg.find("class=\"u-bar\"", p + 1)) {
    ++u_bars;
  }
  EXPECT_EQ(u_bars, 9u);  // each of them with its U (k = 2)
  EXPECT_NE(svg.find("data-quantity=\"squareness\""), std::string::npos);
}

TEST_P(History, LimitsMakeItAPassFailCheckOfTheLatestTest) {
  const auto store = open_store(url_);
  store->add(record_from_result(simulated_result(0.030, "2026-01-05", dir_), nullptr));
  store->add(record_from_result(simulated_result(0.012, "2026-04-01", dir_), nullptr));
  Result r = run(circana("history --machine VMC-3 --limits H=0.015"), dir_);
  EXPECT_EQ(r.code, 0) << r.err;  // the old breach is history; the latest is within
  // Judged with the stored U (k = 2), the rule printed.
  EXPECT_TRUE(std::regex_search(r.out, std::regex(R"(FAIL: H 30\.0 - U \d\.\d > 15\.0 um)")))
      << r.out;
  EXPECT_NE(r.out.find("Latest test (2026-04-01): within the limits"), std::string::npos);
  EXPECT_NE(r.out.find(std::string("Decision rule: ") + history::kDecisionRule), std::string::npos);
  r = run(circana("history --machine VMC-3 --limits H=0.009,G=0.5"), dir_);
  EXPECT_EQ(r.code, 9) << r.err;
  EXPECT_EQ(r.err, "");
  EXPECT_TRUE(
      std::regex_search(r.out, std::regex(R"(OUT OF TOLERANCE: H 12\.0 - U \d\.\d > 9\.0 um\n)")))
      << r.out;
  // A limit on what was not measured fails: a check that cannot be made does not pass.
  r = run(circana("history --machine VMC-3 --limits backlash=0.01 --json"), dir_);
  EXPECT_EQ(r.code, 9);
  EXPECT_EQ(nlohmann::json::parse(r.out)["pass"], false);
  r = run(circana("history --machine VMC-3 --limits H=abc"), dir_);
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err,
            "circana: error: --limits H: expected a limit in mm above 0 and at most 10, got "
            "'abc'\n");
}

// diagnose --store keeps the diagnosis: the backlash and squareness columns are the
// simulator's injected errors, and --limits checks them.
TEST_P(History, DiagnoseStoreFillsBacklashAndSquareness) {
  sim::MachineModel m;
  m.x.backlash_mm = 0.008;
  m.squareness_rad = 40e-6;
  sim::CircleProgram p;
  p.period_s = 0.004;
  Trace t = sim::simulate(m, p);
  t.metadata.set("machine", "VMC-3");
  t.metadata.set("date", "2026-05-01");
  const fs::path trace = dir_ / "diag.csv";
  write_trace(trace.string(), t);
  // store TRACE keeps no diagnosis: a backlash limit cannot be checked.
  Result r = run(circana("store " + trace.string()), dir_);
  ASSERT_EQ(r.code, 0) << r.err;
  r = run(circana("history --machine VMC-3 --limits backlash=0.02"), dir_);
  EXPECT_EQ(r.code, 9) << r.out;
  EXPECT_NE(r.out.find("backlash not measured (no diagnosis stored)"), std::string::npos) << r.out;

  r = run(circana("diagnose " + trace.string() + " --store"), dir_);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("Stored as test 2 of machine VMC-3 (tested at 2026-05-01)"),
            std::string::npos)
      << r.out;
  const auto tests = open_store(url_)->tests("VMC-3", "");
  ASSERT_EQ(tests.size(), 2u);
  const TestRecord& d = tests[1];
  ASSERT_TRUE(d.backlash_mm);
  EXPECT_NEAR(*d.backlash_mm, 0.008, 0.0004);
  ASSERT_TRUE(d.squareness_urad);
  EXPECT_NEAR(*d.squareness_urad, 40.0, 2.0);
  EXPECT_EQ(d.diagnosis["schema"], "circtest.diagnosis/1");
  ASSERT_TRUE(d.h_mm);
  EXPECT_NEAR(*d.h_mm, 0.008, 0.0005);
  EXPECT_FALSE(tests[0].backlash_mm);
  r = run(circana("history --machine VMC-3 --limits backlash=0.01,squareness=50"), dir_);
  EXPECT_EQ(r.code, 0) << r.out;
  r = run(circana("history --machine VMC-3 --limits backlash=0.005 --json"), dir_);
  EXPECT_EQ(r.code, 9) << r.out;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_NEAR(j["tests"][1]["backlash"].get<double>(), 0.008, 0.0004);
  EXPECT_NEAR(j["tests"][1]["squareness_urad"].get<double>(), 40.0, 2.0);
  r = run(circana("history --machine VMC-3 --limits squareness=30"), dir_);
  EXPECT_EQ(r.code, 9) << r.out;
  // --json with --store prints the diagnosis document only.
  r = run(circana("diagnose " + trace.string() + " --store --json"), dir_);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["schema"], "circtest.diagnosis/1");
}

TEST_P(History, BadRequestsGiveClearErrors) {
  open_store(url_)->add(record_from_result(simulated_result(0.01, "2026-01-05", dir_), nullptr));
  Result r = run(circana("history --machine VMC-9"), dir_);
  EXPECT_EQ(r.code, 5);
  EXPECT_EQ(r.out, "");
  EXPECT_NE(r.err.find("no tests of machine 'VMC-9' (machines in the history: VMC-3)"),
            std::string::npos)
      << r.err;
  r = run(circana("history --machine VMC-3 --since yesterday"), dir_);
  EXPECT_EQ(r.code, 2);
  // A trace without a machine name cannot go into a per-machine history.
  const fs::path json = dir_ / "r.json";
  auto doc = simulated_result(0.01, "2026-01-06", dir_);
  doc["conditions"].erase("machine");
  std::ofstream(json) << doc.dump();
  r = run(circana("store " + json.string()), dir_);
  EXPECT_EQ(r.code, 5);
  EXPECT_EQ(r.err,
            "circana: error: no machine name: give --machine NAME or record it in the trace "
            "(# machine: NAME)\n");
  r = run(circana("store " + json.string() + " --machine VMC-4"), dir_);
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("Stored as test 2 of machine VMC-4"), std::string::npos) << r.out;
}

TEST_P(History, ADatabaseOfANewerSchemaIsRefused) {
  { const auto store = open_store(url_); }
  // What a newer circtest would have left: a higher version.
  if (GetParam() == Backend::sqlite) {
    ASSERT_EQ(
        std::system(("sqlite3 '" + url_ + "' 'INSERT INTO circtest_schema VALUES (99)'").c_str()),
        0);
  } else {
    const auto q = url_.find('?');
    const std::string db =
        url_.substr(std::string("postgresql:///").size(), q - std::string("postgresql:///").size());
    ASSERT_EQ(std::system(
                  ("psql -q '" + url_ + "' -c 'INSERT INTO circtest_schema VALUES (99)'").c_str()),
              0)
        << db;
  }
  try {
    open_store(url_);
    FAIL() << "a newer schema was accepted";
  } catch (const DatabaseError& e) {
    EXPECT_NE(
        std::string(e.what()).find(fmt::format(
            "schema version 99, newer than this circtest knows ({})", latest_schema_version())),
        std::string::npos)
        << e.what();
  }
  const Result r = run(circana("history --machine X"), dir_);
  EXPECT_EQ(r.code, 11);
  EXPECT_EQ(r.out, "");
}

// Two machines finishing together: two processes, 200 stores each, none lost.
TEST_P(History, ConcurrentStoresFromTwoProcessesLoseNothing) {
  open_store(url_);  // created first, so the race is between stores, not migrations
  const nlohmann::json doc = simulated_result(0.01, "2026-01-05", dir_);
  constexpr int kPerProcess = 200;
  std::vector<pid_t> children;
  for (int p = 0; p < 2; ++p) {
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      int code = 0;
      try {
        const auto store = open_store(url_);
        for (int i = 0; i < kPerProcess; ++i) {
          TestRecord r = record_from_result(doc, nullptr, fmt::format("M{}", p));
          r.tested_at = fmt::format("2026-01-05T00:{:02d}:{:02d}Z", i / 60, i % 60);
          store->add(r);
        }
      } catch (const std::exception& e) {
        std::fprintf(stderr, "child %d: %s\n", p, e.what());
        code = 1;
      }
      _exit(code);
    }
    children.push_back(pid);
  }
  for (pid_t pid : children) {
    int status = 0;
    waitpid(pid, &status, 0);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  }
  const auto store = open_store(url_);
  for (int p = 0; p < 2; ++p) {
    const auto tests = store->tests(fmt::format("M{}", p), "");
    ASSERT_EQ(tests.size(), static_cast<std::size_t>(kPerProcess));
    for (const auto& t : tests) EXPECT_EQ(t.measures.size(), 7u);
  }
}

// A store cut off in the middle (the process killed, the server crashing) leaves whole tests
// only: each test has all its measures or is not there.
TEST_P(History, AStoreCutOffLeavesNoHalfTest) {
  // The server is killed here: never the fixture's, which other test processes use.
  PostgresServer* server = g_server;
  std::unique_ptr<PostgresServer> own;
  if (GetParam() == Backend::postgresql && !g_server->owned()) {
    own = std::make_unique<PostgresServer>();
    own->create_database("cut");
    url_ = own->url("cut");
    server = own.get();
  }
  open_store(url_);
  const nlohmann::json doc = simulated_result(0.01, "2026-01-05", dir_);
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    try {
      const auto store = open_store(url_);
      for (int i = 0;; ++i) store->add(record_from_result(doc, nullptr));
    } catch (...) {
    }
    _exit(0);
  }
  usleep(400000);
  if (GetParam() == Backend::sqlite) {
    ::kill(pid, SIGKILL);
  } else {
    server->kill();
  }
  int status = 0;
  waitpid(pid, &status, 0);
  if (GetParam() == Backend::postgresql) server->start();
  const auto tests = open_store(url_)->tests("VMC-3", "");
  EXPECT_GT(tests.size(), 0u);
  for (const auto& t : tests) EXPECT_EQ(t.measures.size(), 7u) << "test " << t.id;
}

INSTANTIATE_TEST_SUITE_P(Backends, History, ::testing::Values(Backend::sqlite, Backend::postgresql),
                         name);

TEST(HistorySqlite, ACorruptFileIsAClearError) {
  const circtest::testing::ScratchDir scratch("circtest-corrupt");
  const fs::path dir = scratch.dir();
  const fs::path db = dir / "history.sqlite";
  std::ofstream(db) << std::string(4096, 'x');
  const Result r =
      run(std::string(CIRCANA_PATH) + " history --machine VMC-3 --db " + db.string(), dir);
  EXPECT_EQ(r.code, 11);
  EXPECT_EQ(r.out, "");
  EXPECT_EQ(r.err, "circana: error: " + db.string() +
                       ": not a usable SQLite history database (file is not a database): move "
                       "it away or give another --db\n");
  EXPECT_EQ(slurp(db), std::string(4096, 'x'));  // left as it was
}

TEST(HistoryPostgres, AStoreWhileTheServerIsStoppedFailsAndWritesNothing) {
  PostgresServer server;
  const circtest::testing::ScratchDir scratch("circtest-pgstop");
  const fs::path dir = scratch.dir();
  open_store(server.url())
      ->add(record_from_result(simulated_result(0.01, "2026-01-05", dir), nullptr));
  const fs::path json = dir / "r.json";
  std::ofstream(json) << simulated_result(0.02, "2026-02-05", dir).dump();
  server.stop();
  const Result r = run(
      std::string(CIRCANA_PATH) + " store " + json.string() + " --db '" + server.url() + "'", dir);
  EXPECT_EQ(r.code, 11);
  EXPECT_EQ(r.out, "");
  EXPECT_NE(r.err.find("cannot connect to the history server"), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1);
  server.start();
  const auto tests = open_store(server.url())->tests("VMC-3", "");
  ASSERT_EQ(tests.size(), 1u);
  EXPECT_EQ(tests[0].tested_at, "2026-01-05");
}

// Library text names no command-line option: history_record used as a library says
// what to give in its own words; circana store words it as --machine (BadRequestsGiveClearErrors).
TEST(HistoryRecord, NoMachineNameNamesNoOption) {
  const circtest::testing::ScratchDir scratch("circtest-record");
  const fs::path dir = scratch.dir();
  auto doc = simulated_result(0.01, "2026-01-06", dir);
  doc["conditions"].erase("machine");
  try {
    record_from_result(doc, nullptr);
    ADD_FAILURE() << "no error without a machine name";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ExitCode::data);
    EXPECT_EQ(std::string(e.what()),
              "no machine name: give the machine name argument or record it in the trace "
              "(# machine: NAME)");
  }
  EXPECT_EQ(record_from_result(doc, nullptr, "VMC-4").machine, "VMC-4");
}

// The test's time is a real date, kept in one form that sorts in time order; a date that is
// none is refused with its key rather than stored as the test's time.
TEST(HistoryRecord, TheTestTimeIsARealDateInUtc) {
  const circtest::testing::ScratchDir scratch("circtest-date");
  const fs::path dir = scratch.dir();
  auto doc = simulated_result(0.01, "2026-01-06", dir);
  EXPECT_EQ(record_from_result(doc, nullptr).tested_at, "2026-01-06");
  doc["conditions"]["start_time"] = "2026-11-23T00:30:00+01:00";
  EXPECT_EQ(record_from_result(doc, nullptr).tested_at, "2026-11-22T23:30:00Z");
  for (const char* bad : {"2026-02-30", "2026-13-45", "last week", "2026-11-23T10:00:00 CET"}) {
    doc["conditions"]["start_time"] = bad;
    EXPECT_ERROR(record_from_result(doc, nullptr), ExitCode::data,
                 std::string("'start_time': expected an ISO 8601 date YYYY-MM-DD or date-time "
                             "YYYY-MM-DDTHH:MM:SSZ (a real one), got '") +
                     bad + "'");
  }
}

// No number that is not finite reaches the history: the record refuses it with its name, the
// store refuses it from any caller, and one stored by an older version shows as n/a.
TEST(HistoryRecord, NumbersThatAreNotFiniteAreNeverStoredOrShown) {
  const circtest::testing::ScratchDir scratch("circtest-numbers");
  const fs::path dir = scratch.dir();
  const auto doc = simulated_result(0.01, "2026-01-06", dir);
  Evaluation ev = evaluation_from_json(nlohmann::ordered_json::parse(doc.dump()));
  ev.hysteresis.front().h_mm = INFINITY;
  EXPECT_ERROR(history_record(ev, nullptr, "VMC-3"), ExitCode::data,
               "H = inf is not a usable number (finite, at most 1e+09 in size): not stored");

  const auto store = open_store((dir / "h.sqlite").string());
  TestRecord good = record_from_result(doc, nullptr);
  TestRecord r = good;
  r.h_mm = INFINITY;
  EXPECT_ERROR(store->add(r), ExitCode::data, "history record: H = inf is not a finite number");
  r = good;
  r.measures.front().value_mm = NAN;
  EXPECT_ERROR(store->add(r), ExitCode::data, "is not a finite number");
  r = good;
  r.machine = "M\xE4hwerk";
  EXPECT_ERROR(store->add(r), ExitCode::data, "history record: machine is not UTF-8 text");
  r = good;
  r.tested_at = "yesterday";
  EXPECT_ERROR(store->add(r), ExitCode::data, "tested_at 'yesterday' is not an ISO 8601");
  EXPECT_TRUE(store->machines().empty());

  r = good;
  r.h_mm = INFINITY;
  r.g_mm = 1e308;
  const std::string text = history_text("VMC-3", {r}, {});
  EXPECT_EQ(text.find("inf"), std::string::npos) << text;
  EXPECT_NE(text.find("n/a"), std::string::npos) << text;
  Limits limits;
  limits.g_mm = 0.02;
  EXPECT_EQ(breaches(r, limits), std::vector<std::string>{"G n/a > 20.0 um"});
}

// The library names its settings in its own words unless the front end gives its option.
TEST(HistoryLimits, RefusalsNameTheSettingAsTheCallerDoes) {
  EXPECT_EQ(*parse_limits("H=0.015,squareness=40").squareness_urad, 40.0);
  auto message = [](const std::string& text, auto... setting) {
    try {
      parse_limits(text, setting...);
    } catch (const UsageError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(message("G=-1"), "limits G: expected a limit in mm above 0 and at most 10, got '-1'");
  EXPECT_EQ(message("G=-1", "--limits"),
            "--limits G: expected a limit in mm above 0 and at most 10, got '-1'");
  // A limit no circular test can come near is a slip, and would print as "inf" scaled to um.
  EXPECT_EQ(message("H=1e308", "--limits"),
            "--limits H: expected a limit in mm above 0 and at most 10, got '1e308'");
  EXPECT_EQ(message("squareness=20000"),
            "limits squareness: expected a limit in urad above 0 and at most 10000, got '20000'");
  EXPECT_EQ(message("Q=1").rfind("limits: expected NAME=VALUE", 0), 0u) << message("Q=1");
}
