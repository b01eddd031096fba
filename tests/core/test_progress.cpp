// The status line of long work: drawn on a terminal only, after its delay, in place; never
// on a pipe or a file.
#include "circtest/core/progress.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <string>
#include <thread>

#include "pty_capture.hpp"

using circtest::ProgressLine;
using circtest::ProgressTicker;
using circtest::testing::PtyCapture;

TEST(Progress, TellsATerminalFromAPipeAndAFile) {
  PtyCapture pty;
  EXPECT_TRUE(circtest::is_terminal(pty.terminal()));
  int fds[2];
  ASSERT_EQ(::pipe(fds), 0);
  std::FILE* pipe = ::fdopen(fds[1], "w");
  EXPECT_FALSE(circtest::is_terminal(pipe));
  std::fclose(pipe);
  ::close(fds[0]);
  std::FILE* file = std::tmpfile();
  EXPECT_FALSE(circtest::is_terminal(file));
  std::fclose(file);
}

TEST(Progress, ALineAppearsAfterItsDelayAndIsRedrawnInPlace) {
  PtyCapture pty;
  {
    ProgressLine line(pty.terminal(), "tool", true, 10.0, 1.0, 0.2);
    line.update(10.5, "too early");         // within the delay
    line.update(11.0, "1 s, 100 samples");  // drawn
    line.update(11.1, "1 s, 110 samples");  // within the interval: not drawn
    line.update(11.3, "1 s, 130 samples");  // drawn
    line.update(11.6, "1 s, 130 samples");  // the same text: not drawn again
  }                                         // cleared
  EXPECT_EQ(pty.finish(), "\rtool: 1 s, 100 samples\033[K\rtool: 1 s, 130 samples\033[K\r\033[K");
}

TEST(Progress, NothingWhenNotEnabled) {
  PtyCapture pty;
  {
    ProgressLine line(pty.terminal(), "tool", false, 0.0, 0.0, 0.0);
    line.update(5.0, "hidden");
    line.clear();
  }
  EXPECT_EQ(pty.finish(), "");
}

TEST(Progress, ATickerShowsItsStageOnATerminalAndLeavesNoTrace) {
  ::setenv("CIRCTEST_PROGRESS_AFTER_S", "0", 1);
  PtyCapture pty;
  {
    ProgressTicker ticker("circana analyze", pty.terminal());
    ticker.stage("reading big.csv");
    std::this_thread::sleep_for(std::chrono::milliseconds(350));
  }
  const std::string shown = pty.finish();
  EXPECT_NE(shown.find("\rcircana analyze: reading big.csv (0 s)\033[K"), std::string::npos)
      << shown;
  EXPECT_TRUE(shown.ends_with("\r\033[K")) << shown;
  // On a file (not a terminal) it writes nothing.
  std::FILE* file = std::tmpfile();
  {
    ProgressTicker ticker("circana analyze", file);
    ticker.stage("reading big.csv");
    std::this_thread::sleep_for(std::chrono::milliseconds(250));
  }
  EXPECT_EQ(std::ftell(file), 0L);
  std::fclose(file);
  ::unsetenv("CIRCTEST_PROGRESS_AFTER_S");
}

TEST(Progress, TheDelayComesFromTheEnvironmentWhenItIsAPlausibleNumber) {
  ::setenv("CIRCTEST_PROGRESS_AFTER_S", "2.5", 1);
  EXPECT_EQ(circtest::progress_delay_s(), 2.5);
  for (const char* bad : {"-1", "nan", "1e9", "soon", ""}) {
    ::setenv("CIRCTEST_PROGRESS_AFTER_S", bad, 1);
    EXPECT_EQ(circtest::progress_delay_s(), 1.0) << bad;
  }
  ::unsetenv("CIRCTEST_PROGRESS_AFTER_S");
  EXPECT_EQ(circtest::progress_delay_s(), 1.0);
}
