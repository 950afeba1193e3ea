// Write failures: a file-size limit (ulimit -f), an injected failure of each artifact type at a
// middle frame (ROADSURVEY_INJECT_WRITE_FAILURE, as a full disk would fail it) and a real full
// disk (a small tmpfs, where mounting is permitted). Each must exit 1 naming the file, print the
// summary, finish the manifest as failed and cache nothing corrupt: a re-run without the fault
// publishes exactly what a clean run does, and no temporary name is left.
#include <sys/mount.h>

#include <cerrno>
#include <cstring>

#include "tests/fault/fault_fixture.h"

namespace rs::test {
namespace {
namespace fs = std::filesystem;

class FaultWrites : public FaultTest {
 protected:
  // The checks every write failure must pass; `file` is the name the message must contain.
  static void ExpectCleanFailure(const fs::path& out, const ProgramResult& r, const std::string& file) {
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_NE(r.output.find(file), std::string::npos) << "the message must name " << file << ":\n" << r.output;
    EXPECT_NE(r.output.find("stage        status"), std::string::npos) << "no summary printed:\n" << r.output;
    ASSERT_TRUE(fs::exists(out / "manifest.json")) << r.output;
    EXPECT_EQ(Manifest(out)["run"]["state"], "failed");
    EXPECT_EQ(TemporaryNames(out), std::vector<std::string>{});
  }
  // A re-run without the fault gives a clean run's outputs: nothing corrupt was cached.
  static void ExpectRecovery(const fs::path& out, const std::map<std::string, std::string>& clean,
                             const std::string& extra = "") {
    const auto again = Run(out, extra);
    ASSERT_EQ(again.exit_code, 0) << again.output;
    EXPECT_EQ(Differences(clean, PublishedFiles(out)), std::vector<std::string>{});
    EXPECT_EQ(TemporaryNames(out), std::vector<std::string>{});
  }
};

// `ulimit -f` counts 512-byte blocks in /bin/sh (dash, and bash in POSIX mode): 1200 = 600 KiB.
// The per-frame float TIFFs (about 0.9 MB each) exceed it; every other file fits.
constexpr const char* kFileSizeLimit = "ulimit -f 1200;";

// With SIGXFSZ ignored (as some shells and services leave it) the damage stage's TIFF write errors
// used to be ignored: exit 0, truncated TIFFs published, cached and reused by every later run.
// (The disparity stage's TIFF is switched off so that the damage stage is the first to hit it.)
TEST_F(FaultWrites, FileSizeLimitWithSignalIgnored) {
  const fs::path out = Output("ulimit_ignored");
  const std::string extra = "--disparity.write_transformed false";
  const auto clean = CleanRunFiles(out, extra);
  const auto r = Run(out, extra, std::string("trap '' XFSZ; ") + kFileSizeLimit);
  ExpectCleanFailure(out, r, ".tiff");
  EXPECT_NE(r.output.find("damage/"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("File too large"), std::string::npos) << r.output;
  ExpectRecovery(out, clean, extra);
}

// With the default SIGXFSZ action the kernel used to kill the run mid-write (no message, no
// summary, manifest left "running"); roadsurvey ignores the signal and reports the write.
TEST_F(FaultWrites, FileSizeLimitWithDefaultSignal) {
  const fs::path out = Output("ulimit_default");
  const auto clean = CleanRunFiles(out);
  const auto r = Run(out, "", std::string("trap - XFSZ; ") + kFileSizeLimit);
  ExpectCleanFailure(out, r, "transformed.tiff");
  ExpectRecovery(out, clean);
}

struct InjectedCase {
  const char* artifact;  // for the test name
  const char* inject;    // ROADSURVEY_INJECT_WRITE_FAILURE
  const char* file;      // the name the message must contain
  const char* extra;     // run options
};

class InjectedWriteFailure : public FaultWrites, public ::testing::WithParamInterface<InjectedCase> {};

// Each artifact type, at a middle frame (the 4th of 8 written) where it is written per frame.
TEST_P(InjectedWriteFailure, ExitsOneNamingTheFileAndCachesNothingCorrupt) {
  const InjectedCase& c = GetParam();
  const fs::path out = Output(std::string("inject_") + c.artifact);
  const auto clean = CleanRunFiles(out, c.extra);
  const auto r = Run(out, c.extra, std::string("ROADSURVEY_INJECT_WRITE_FAILURE=") + c.inject);
  ExpectCleanFailure(out, r, c.file);
  EXPECT_NE(r.output.find("No space left on device"), std::string::npos) << r.output;
  ExpectRecovery(out, clean, c.extra);
}

INSTANTIATE_TEST_SUITE_P(
    EveryArtifactType, InjectedWriteFailure,
    ::testing::Values(InjectedCase{"tiff", "depth_below_road_mm.tiff@4", "depth_below_road_mm.tiff", ""},
                      InjectedCase{"png", "disparity.png@4", "disparity.png", ""},
                      InjectedCase{"json", "detections.json@4", "detections.json", ""},
                      InjectedCase{"csv", "frame_status.csv", "frame_status.csv", ""},
                      InjectedCase{"ply", "cloud.ply@4", "cloud.ply", "--disparity.write_point_cloud true"},
                      InjectedCase{"published_json", "ingest.json", "ingest.json", ""}),
    [](const ::testing::TestParamInfo<InjectedCase>& info) { return std::string(info.param.artifact); });

// A full disk while writing the manifest: the run still finishes with the summary, exit 1 and the
// manifest's final state "failed" with the error (it used to exit 2, the code for bad input).
TEST_F(FaultWrites, ManifestWriteFailureFinishesAsFailed) {
  const fs::path out = Output("manifest");
  const auto clean = CleanRunFiles(out);
  const auto r = Run(out, "", "ROADSURVEY_INJECT_WRITE_FAILURE=manifest.json@2");
  ExpectCleanFailure(out, r, "manifest.json");
  EXPECT_NE(Manifest(out).value("error", std::string()).find("manifest.json"), std::string::npos);
  ExpectRecovery(out, clean);
}

// A real full disk: a 6 MiB tmpfs (a clean run writes about 27 MB). Needs permission to mount.
TEST_F(FaultWrites, DiskFull) {
  const fs::path out = Output("disk_full");
  fs::create_directories(out);
  if (::mount("tmpfs", out.c_str(), "tmpfs", 0, "size=6m") != 0)
    GTEST_SKIP() << "cannot mount a tmpfs here (" << std::strerror(errno)
                 << "): the full-disk case is covered by the injected failures";
  struct Unmount {
    fs::path dir;
    ~Unmount() { ::umount2(dir.c_str(), MNT_DETACH); }
  } unmount{out};
  const auto r = Run(out);
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("No space left on device"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("stage        status"), std::string::npos) << "no summary printed:\n" << r.output;
  ASSERT_TRUE(fs::exists(out / "manifest.json")) << r.output;
  EXPECT_EQ(Manifest(out)["run"]["state"], "failed");
  EXPECT_EQ(TemporaryNames(out), std::vector<std::string>{});
}

}  // namespace
}  // namespace rs::test
