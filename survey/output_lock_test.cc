#include "survey/output_lock.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fstream>

namespace rs {
namespace {
namespace fs = std::filesystem;

fs::path FreshDir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("rs_lock_" + std::to_string(::getpid())) / name;
  fs::remove_all(dir);
  return dir;
}

TEST(OutputLock, SecondHolderIsRefusedWithTheFirstNamed) {
  const fs::path dir = FreshDir("held");
  const LockHolder self = LockHolder::Self("2026-11-28T02:15:00Z");
  {
    const OutputLock lock = OutputLock::Acquire(dir, self);
    EXPECT_FALSE(lock.taken_over_from());
    const auto holder = OutputLock::ReadHolder(dir);
    ASSERT_TRUE(holder);
    EXPECT_EQ(holder->pid, ::getpid());
    // flock(2) locks belong to the open file, so a second open in this process conflicts too.
    try {
      OutputLock::Acquire(dir, self);
      FAIL() << "expected OutputLockedError";
    } catch (const OutputLockedError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("PID " + std::to_string(::getpid())), std::string::npos) << what;
      EXPECT_NE(what.find("2026-11-28T02:15:00Z"), std::string::npos) << what;
      EXPECT_NE(what.find(dir.string()), std::string::npos) << what;
    }
  }
  EXPECT_FALSE(fs::exists(dir / OutputLock::kFileName));  // released: removed
  const OutputLock again = OutputLock::Acquire(dir, self);
  EXPECT_FALSE(again.taken_over_from());
}

// A holder killed without releasing (here: a child that locks and _exits) leaves its file; the
// next run takes the lock over and says whose it was.
TEST(OutputLock, StaleLockIsTakenOver) {
  const fs::path dir = FreshDir("stale");
  const pid_t child = ::fork();
  if (child == 0) {
    auto lock = new OutputLock(OutputLock::Acquire(dir, LockHolder::Self("2026-11-28T01:00:00Z")));
    (void)lock;
    ::_exit(0);  // no destructor: the file stays, the kernel drops the lock
  }
  int status = 0;
  ::waitpid(child, &status, 0);
  ASSERT_TRUE(fs::exists(dir / OutputLock::kFileName));
  const auto stale = OutputLock::ReadHolder(dir);
  ASSERT_TRUE(stale);
  EXPECT_EQ(stale->pid, child);
  EXPECT_FALSE(stale->MaybeAlive());
  const OutputLock lock = OutputLock::Acquire(dir, LockHolder::Self("2026-11-28T02:00:00Z"));
  ASSERT_TRUE(lock.taken_over_from());
  EXPECT_EQ(lock.taken_over_from()->pid, child);
  EXPECT_EQ(lock.taken_over_from()->started_utc, "2026-11-28T01:00:00Z");
  EXPECT_EQ(OutputLock::ReadHolder(dir)->pid, ::getpid());
}

TEST(OutputLock, LiveHolderIsAlive) { EXPECT_TRUE(LockHolder::Self("t").MaybeAlive()); }

}  // namespace
}  // namespace rs
