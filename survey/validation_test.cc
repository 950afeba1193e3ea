#include "survey/validation.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <fstream>

namespace rs {
namespace {
namespace fs = std::filesystem;

TEST(CheckOutputFolder, AFileAtOrAboveTheOutputIsAnError) {
  const fs::path root = fs::temp_directory_path() / ("rs_validation_" + std::to_string(::getpid()));
  fs::remove_all(root);
  fs::create_directories(root / "folder");
  std::ofstream(root / "file") << "x";

  ProblemList ok;
  CheckOutputFolder(root / "folder", ok);
  CheckOutputFolder(root / "new" / "deeper", ok);  // created by the run
  EXPECT_TRUE(ok.items().empty());

  ProblemList is_file;
  CheckOutputFolder(root / "file", is_file);
  ASSERT_EQ(is_file.ErrorCount(), 1);
  EXPECT_EQ(is_file.items()[0].where.path, (root / "file").string());
  EXPECT_NE(is_file.items()[0].message.find("is a file"), std::string::npos);

  ProblemList under_file;
  CheckOutputFolder(root / "file" / "out", under_file);
  ASSERT_EQ(under_file.ErrorCount(), 1);
  EXPECT_EQ(under_file.items()[0].where.path, (root / "file").string());
  EXPECT_NE(under_file.items()[0].message.find((root / "file" / "out").string()), std::string::npos);
  fs::remove_all(root);
}

}  // namespace
}  // namespace rs
