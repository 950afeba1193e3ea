#include "formats/checked_file.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <unistd.h>

#include <cstring>
#include <fstream>
#include <iterator>
#include <string>

namespace rs {
namespace {
namespace fs = std::filesystem;

fs::path TempDir() {
  const fs::path dir = fs::temp_directory_path() / ("rs_checked_file_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir;
}

std::string Slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

TEST(CheckedFile, Nominal) {
  const fs::path p = TempDir() / "a.bin";
  std::string bytes(100000, '\0');
  for (size_t i = 0; i < bytes.size(); ++i) bytes[i] = static_cast<char>(i * 7);
  WriteFileChecked(p, bytes);
  EXPECT_EQ(Slurp(p), bytes);
  WriteFileChecked(p, "short");  // truncates
  EXPECT_EQ(Slurp(p), "short");
  WriteStreamChecked(p, [](std::ostream& out) { out << "x=" << 42 << '\n'; });
  EXPECT_EQ(Slurp(p), "x=42\n");
  fs::remove_all(p.parent_path());
}

TEST(CheckedFile, MissingFolderNamesTheFile) {
  const fs::path p = TempDir() / "no_such_folder" / "a.bin";
  try {
    WriteFileChecked(p, "x");
    FAIL() << "expected WriteError";
  } catch (const WriteError& e) {
    EXPECT_EQ(e.path(), p);
    EXPECT_NE(std::string(e.what()).find(p.string()), std::string::npos) << e.what();
  }
}

TEST(CheckedFile, DiskFull) {
  if (!fs::exists("/dev/full")) GTEST_SKIP() << "/dev/full is not available on this platform";
  try {
    WriteFileChecked("/dev/full", std::string(10000, 'x'));
    FAIL() << "expected WriteError";
  } catch (const WriteError& e) {
    EXPECT_EQ(e.reason(), std::strerror(ENOSPC));
  }
  EXPECT_TRUE(fs::exists("/dev/full"));  // the device is not removed like a partial file
}

// A file-size limit (ulimit -f) with SIGXFSZ ignored, as roadsurvey runs: the write fails with
// EFBIG, the error names the file and the truncated file is removed.
TEST(CheckedFile, FileSizeLimit) {
  const fs::path p = TempDir() / "big.bin";
  rlimit old{};
  ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &old), 0);
  const auto old_handler = ::signal(SIGXFSZ, SIG_IGN);
  rlimit small = old;
  small.rlim_cur = 4096;
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &small), 0);
  std::string error;
  try {
    WriteFileChecked(p, std::string(10000, 'x'));
  } catch (const WriteError& e) {
    error = e.reason();
  }
  ::setrlimit(RLIMIT_FSIZE, &old);
  ::signal(SIGXFSZ, old_handler);
  EXPECT_EQ(error, std::strerror(EFBIG));
  EXPECT_FALSE(fs::exists(p));
  fs::remove_all(p.parent_path());
}

}  // namespace
}  // namespace rs
