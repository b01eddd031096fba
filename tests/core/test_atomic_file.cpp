// Output paths: what write_file_atomic and TraceWriter may replace, and what a killed writer
// leaves behind. Real FIFOs, device nodes, directories and symbolic links in a scratch dir.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "circtest/core/atomic_file.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/trace.hpp"

namespace fs = std::filesystem;
using namespace circtest;

namespace {

class AtomicFile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("circtest-atomic-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string path(const std::string& name) const { return (dir_ / name).string(); }

  std::vector<std::string> entries() const {
    std::vector<std::string> out;
    for (const auto& e : fs::directory_iterator(dir_)) out.push_back(e.path().filename());
    std::sort(out.begin(), out.end());
    return out;
  }

  // The IoError message of writing `content` to `p`, or "" when it succeeded.
  static std::string refusal(const std::string& p) {
    try {
      write_file_atomic(p, "content\n");
    } catch (const IoError& e) {
      EXPECT_EQ(e.code(), ExitCode::io);
      return e.what();
    }
    return "";
  }

  fs::path dir_;
};

}  // namespace

TEST_F(AtomicFile, ReplacesAndKeepsBackup) {
  const std::string p = path("machine.ini");
  write_file_atomic(p, "old\n");
  ::chmod(p.c_str(), 0600);
  write_file_atomic(p, "new\n", {.keep_backup = true});
  EXPECT_EQ(read_file(p), "new\n");
  EXPECT_EQ(read_file(p + ".bak"), "old\n");
  EXPECT_EQ(fs::status(p).permissions() & fs::perms::all,
            fs::perms::owner_read | fs::perms::owner_write);
  EXPECT_EQ(entries(), (std::vector<std::string>{"machine.ini", "machine.ini.bak"}));
}

TEST_F(AtomicFile, MissingDirectoryIsAnIoError) {
  const std::string msg = refusal(path("no-such-dir/x.ini"));
  EXPECT_NE(msg.find("no-such-dir/x.ini: cannot create a file in"), std::string::npos) << msg;
}

TEST_F(AtomicFile, RefusesAFifo) {
  const std::string p = path("pipe");
  ASSERT_EQ(::mkfifo(p.c_str(), 0644), 0);
  EXPECT_EQ(refusal(p), p + ": is a FIFO, not a regular file; refusing to replace it");
  EXPECT_TRUE(fs::is_fifo(p));
  EXPECT_EQ(entries(), std::vector<std::string>{"pipe"});
}

TEST_F(AtomicFile, RefusesADirectory) {
  const std::string p = path("sub");
  fs::create_directory(p);
  EXPECT_EQ(refusal(p), p + ": is a directory, not a regular file; refusing to replace it");
  EXPECT_TRUE(fs::is_directory(p));
}

TEST_F(AtomicFile, RefusesADeviceNode) {
  // A private copy of /dev/full (char 1,7), so a regression cannot destroy the real one.
  const std::string p = path("full");
  if (::mknod(p.c_str(), S_IFCHR | 0666, makedev(1, 7)) != 0) {
    GTEST_SKIP() << "mknod needs root: " << std::strerror(errno);
  }
  EXPECT_EQ(refusal(p), p + ": is a character device, not a regular file; refusing to replace it");
  EXPECT_TRUE(fs::is_character_file(p));
  // The same through the trace writer (circlog-record -o).
  EXPECT_THROW(TraceWriter(p, {}, {{"x"}}), IoError);
  EXPECT_TRUE(fs::is_character_file(p));
}

TEST_F(AtomicFile, RefusesTheRealDevFull) {
  // Refused before anything is opened, so this is safe even when run as root.
  EXPECT_EQ(refusal("/dev/full"),
            "/dev/full: is a character device, not a regular file; refusing to replace it");
  EXPECT_TRUE(fs::is_character_file("/dev/full"));
}

TEST_F(AtomicFile, SymlinkToARegularFileWritesTheTargetAndKeepsTheLink) {
  fs::create_directory(dir_ / "real");
  const std::string target = path("real/machine.ini");
  write_file_atomic(target, "old\n");
  const std::string link = path("machine.ini");
  fs::create_symlink("real/machine.ini", link);
  write_file_atomic(link, "new\n", {.keep_backup = true});
  EXPECT_TRUE(fs::is_symlink(link));
  EXPECT_EQ(fs::read_symlink(link), "real/machine.ini");
  EXPECT_EQ(read_file(target), "new\n");
  EXPECT_EQ(read_file(target + ".bak"), "old\n");  // beside the file that was replaced
  EXPECT_EQ(entries(), (std::vector<std::string>{"machine.ini", "real"}));
}

TEST_F(AtomicFile, RefusesSymlinksToNonRegularOrMissingFiles) {
  const std::string fifo = path("pipe");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0644), 0);
  fs::create_symlink(fifo, path("to-pipe"));
  EXPECT_EQ(refusal(path("to-pipe")), path("to-pipe") + ": is a symbolic link to " + fifo +
                                          ", which is a FIFO, not a regular file; refusing to "
                                          "replace it");
  fs::create_symlink("/dev/null", path("to-null"));
  EXPECT_NE(refusal(path("to-null")).find("which is a character device"), std::string::npos);
  EXPECT_TRUE(fs::is_character_file("/dev/null"));
  fs::create_symlink("nowhere", path("dangling"));
  EXPECT_NE(refusal(path("dangling")).find("is a symbolic link to a missing file"),
            std::string::npos);
  EXPECT_TRUE(fs::is_symlink(path("to-pipe")));
  EXPECT_TRUE(fs::is_fifo(fifo));
  EXPECT_EQ(entries(), (std::vector<std::string>{"dangling", "pipe", "to-null", "to-pipe"}));
}

TEST_F(AtomicFile, ABackupPathThatIsAFifoIsRefusedAndTheFileKept) {
  const std::string p = path("machine.ini");
  write_file_atomic(p, "old\n");
  ASSERT_EQ(::mkfifo((p + ".bak").c_str(), 0644), 0);
  EXPECT_THROW(write_file_atomic(p, "new\n", {.keep_backup = true}), IoError);
  EXPECT_EQ(read_file(p), "old\n");
  EXPECT_EQ(entries(), (std::vector<std::string>{"machine.ini", "machine.ini.bak"}));
}

TEST_F(AtomicFile, SigkilledWriterLeavesNothingBehind) {
  const std::string p = path("trace.csv");
  write_file_atomic(p, "old\n");
  int ready[2];
  ASSERT_EQ(::pipe(ready), 0);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    // Mid-write: some bytes out, then wait to be killed.
    AtomicOutput out(p);
    out.write(std::string(1 << 20, 'x'));
    TraceWriter w(path("new.ctb"), {}, {{"x"}});
    const double v = 1.0;
    for (int i = 0; i < 200000; ++i) w.write_row(&v);
    (void)!::write(ready[1], "r", 1);
    for (;;) ::pause();
  }
  ::close(ready[1]);
  char c = 0;
  ASSERT_EQ(::read(ready[0], &c, 1), 1);
  ::close(ready[0]);
  ::kill(child, SIGKILL);
  int status = 0;
  ::waitpid(child, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status));
  EXPECT_EQ(read_file(p), "old\n");
  EXPECT_EQ(entries(), std::vector<std::string>{"trace.csv"});
}

TEST_F(AtomicFile, StaleNamedTemporariesOfDeadProcessesAreSwept) {
  // What a writer killed between naming its temporary and the rename (or one on a
  // filesystem without O_TMPFILE) leaves: swept by the next write to the same name.
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) ::_exit(0);
  ::waitpid(child, nullptr, 0);  // now a PID of no process
  const std::string stale = path(".out.svg.circtest-tmp." + std::to_string(child));
  const std::string live = path(".out.svg.circtest-tmp.1");  // init is alive: left alone
  const std::string other = path(".other.svg.circtest-tmp." + std::to_string(child));
  for (const auto& f : {stale, live, other}) write_file_atomic(f, "partial");
  write_file_atomic(path("out.svg"), "<svg/>");
  EXPECT_FALSE(fs::exists(stale));
  EXPECT_TRUE(fs::exists(live));
  EXPECT_TRUE(fs::exists(other));
  EXPECT_EQ(read_file(path("out.svg")), "<svg/>");
}

TEST_F(AtomicFile, TraceWriterFollowsTheSameRules) {
  const std::string fifo = path("trace.csv");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0644), 0);
  EXPECT_THROW(TraceWriter(fifo, {}, {{"x"}}), IoError);
  EXPECT_TRUE(fs::is_fifo(fifo));
  EXPECT_THROW(TraceWriter(dir_.string(), {}, {{"x"}}), IoError);
  {
    TraceWriter w(path("t.ctb"), {}, {{"x"}});
    const double v = 2.0;
    w.write_row(&v);
    EXPECT_EQ(entries(), std::vector<std::string>{"trace.csv"}) << "visible before commit";
    w.commit();
  }
  EXPECT_EQ(entries(), (std::vector<std::string>{"t.ctb", "trace.csv"}));
}
