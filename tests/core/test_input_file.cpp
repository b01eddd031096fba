// Inputs read whole have a limit and never hang on a device or a FIFO: a named input is read
// only when it is a regular file, standard input whatever it is. The digest of a file streams, so a
// trace of any length is hashed.
#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <functional>
#include <future>
#include <string>
#include <string_view>
#include <vector>

#include "circtest/core/atomic_file.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/input_file.hpp"
#include "circtest/core/sha256.hpp"
#include "scratch.hpp"
#include "stdin_pipe.hpp"

namespace {

using namespace circtest;
using circtest::testing::ScratchDir;
using circtest::testing::spit;
using circtest::testing::StdinPipe;

std::string io_error_of(const std::function<void()>& read) {
  try {
    read();
  } catch (const IoError& e) {
    return e.what();
  }
  return "(no IoError)";
}

TEST(InputFile, ADeviceIsRefusedBeforeAByteIsRead) {
  for (const std::string device : {"/dev/zero", "/dev/urandom"}) {
    const std::string what = io_error_of([&] { (void)read_file(device); });
    EXPECT_NE(what.find(device + ": is a character device"), std::string::npos) << what;
    EXPECT_NE(io_error_of([&] { (void)sha256_of_file(device); }).find("character device"),
              std::string::npos);
  }
  ScratchDir dir;
  EXPECT_NE(io_error_of([&] { (void)read_file(dir.path()); }).find("is a directory"),
            std::string::npos);
}

TEST(InputFile, AFileOverTheLimitIsRefusedNamingTheLimit) {
  ScratchDir dir;
  const std::string big = dir.file("big.json");
  spit(big, "");
  ASSERT_EQ(::truncate(big.c_str(), static_cast<off_t>(kMaxWholeInputBytes) + 1), 0);
  const std::string what = io_error_of([&] { (void)read_file(big); });
  EXPECT_NE(what.find(big + ": larger than the limit of 64 MiB"), std::string::npos) << what;
  // A small limit of the caller's own, in bytes when not whole MiB.
  spit(dir.file("small"), "0123456789");
  EXPECT_NE(io_error_of([&] {
              (void)read_input_bytes(dir.file("small"), 9);
            }).find("larger than the limit of 9 bytes"),
            std::string::npos);
  EXPECT_EQ(read_input_bytes(dir.file("small"), 10), "0123456789");
}

TEST(InputFile, APipeOverTheLimitIsRefusedWhileReading) {
  StdinPipe in(std::string(64 * 4096, 'x'));
  const std::string what = io_error_of([&] { (void)read_input_bytes("-", 100000); });
  EXPECT_EQ(what, "-: larger than the limit of 100000 bytes for this input");
}

TEST(InputFile, StandardInputIsReadByEitherName) {
  {
    StdinPipe in("a pipe from another program\n");
    EXPECT_EQ(read_input_text("-"), "a pipe from another program\n");
  }
  StdinPipe in("the same pipe by its name\n");
  EXPECT_EQ(read_input_text("/dev/stdin"), "the same pipe by its name\n");
}

// READ run in another thread; its IoError's text. A read still blocked after 5 s (on a
// FIFO without a writer) is released by opening the FIFO for writing and reported.
std::string io_error_within_5_s(const std::string& fifo,
                                const std::function<void(const std::string&)>& read) {
  auto result = std::async(std::launch::async, [&] { return io_error_of([&] { read(fifo); }); });
  if (result.wait_for(std::chrono::seconds(5)) == std::future_status::ready) return result.get();
  const int fd = ::open(fifo.c_str(), O_WRONLY | O_NONBLOCK);
  if (fd >= 0) ::close(fd);
  return "(still waiting after 5 s) " + result.get();
}

// A FIFO named as an input would wait for a writer (circgen's --parameter-file once hung on
// one): every reader refuses it before opening it, whether or not a writer ever comes.
TEST(InputFile, AFifoIsRefusedBeforeItIsOpened) {
  ScratchDir dir;
  const std::string fifo = dir.file("fifo");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const std::string refusal = fifo + ": is a FIFO, not a regular file";
  const std::vector<std::function<void(const std::string&)>> readers = {
      [](const std::string& p) { (void)read_file(p); },
      [](const std::string& p) { (void)read_input_text(p); },
      [](const std::string& p) { (void)sha256_of_file(p); },
      [](const std::string& p) { InputFile in(p); },
      [](const std::string& p) { for_each_input_block(p, [](std::string_view) {}); }};
  for (std::size_t i = 0; i < readers.size(); ++i) {
    EXPECT_EQ(io_error_within_5_s(fifo, readers[i]), refusal) << "reader " << i;
  }
  // A symbolic link to the FIFO: the same.
  const std::string link = dir.file("link");
  ASSERT_EQ(::symlink(fifo.c_str(), link.c_str()), 0);
  EXPECT_EQ(io_error_within_5_s(link, readers[0]), link + ": is a FIFO, not a regular file");
}

TEST(InputFile, TheStreamedDigestIsTheDigestOfTheBytes) {
  ScratchDir dir;
  std::string text;
  for (int i = 0; i < 300000; ++i) text += static_cast<char>('a' + i % 26);  // several blocks
  spit(dir.file("t"), text);
  EXPECT_EQ(sha256_of_file(dir.file("t")), sha256_hex(text));
  spit(dir.file("empty"), "");
  // FIPS 180-2's digest of the empty message.
  EXPECT_EQ(sha256_of_file(dir.file("empty")),
            "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
}

// Known answers (FIPS 180-2's examples, and messages around the 55/56/64-byte padding edges
// with bytes above 0x7f, digests from Python's hashlib): the digest is computed in core.
TEST(Sha256, KnownAnswers) {
  EXPECT_EQ(sha256_hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(sha256_hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(sha256_hex("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
  const std::pair<std::size_t, const char*> edges[] = {
      {55, "fc0ae310b48cab4c87561a8176615c73acbe8d4abd15fee3e2ac284480a27bdb"},
      {56, "72b488ef4b31f4efb752e00e29fdce47f415909d0474697e364928989d0be415"},
      {63, "6503954d0d83830b435989fd1f25ec16e01aab67b70861a01fe01ef8412f221a"},
      {64, "c471eae7ead2708dcbc0123ebb955a3f689a2125c182f877f30fe7a91814dac1"},
      {65, "5039909c04b54848a1f8e00acb73a5b9470d6baf7403f37f7c6b993467cbd0d3"},
      {119, "487d0a8cf0c8bbddecc1fd5682f73884a7cce425d79b46d234ccda1bb8a0f84e"},
      {120, "e14cbe6a1ebc723b7028c4d746bf683be84d669f4f6b24330b1909c00f5a3dde"}};
  for (const auto& [size, digest] : edges) {
    std::string message;
    for (std::size_t i = 0; i < size; ++i) message += static_cast<char>((i * 7 + 200) % 256);
    EXPECT_EQ(sha256_hex(message), digest) << size << " bytes";
  }
}

TEST(Sha256, AMillionAsStreamedFromAFile) {
  ScratchDir dir;
  spit(dir.file("a"), std::string(1000000, 'a'));
  EXPECT_EQ(sha256_of_file(dir.file("a")),
            "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
}

}  // namespace
