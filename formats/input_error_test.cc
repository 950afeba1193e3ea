#include "formats/input_error.h"

#include <gtest/gtest.h>

namespace rs {
namespace {

TEST(InputLocation, FormatsLineColumnAndByte) {
  EXPECT_EQ(InputLocation::Line("log.csv", 118).ToString(), "log.csv:118");
  EXPECT_EQ(InputLocation::Line("log.csv", 118, 7).ToString(), "log.csv:118:7");
  EXPECT_EQ(InputLocation::Byte("log.ulg", 48213).ToString(), "log.ulg @ byte 48213");
  EXPECT_EQ(InputLocation::File("calib.yaml").ToString(), "calib.yaml");
}

TEST(InputError, WhatNamesLocationAndMessage) {
  InputError e(InputLocation::Line("flight.csv", 3), "expected 9 fields, got 7");
  EXPECT_STREQ(e.what(), "flight.csv:3: expected 9 fields, got 7");
  EXPECT_EQ(e.message(), "expected 9 fields, got 7");
}

TEST(ProblemList, CountsBySeverity) {
  ProblemList problems;
  problems.Error(InputLocation::File("a.png"), "cannot decode");
  problems.Warning(InputLocation::File("b.png"), "dark");
  problems.Add(InputError(InputLocation::Byte("c.bin", 4), "truncated"));
  EXPECT_EQ(problems.ErrorCount(), 2);
  EXPECT_EQ(problems.WarningCount(), 1);
  EXPECT_TRUE(problems.HasErrors());
  EXPECT_EQ(problems.items()[2].ToString(), "error: c.bin @ byte 4: truncated");
}

}  // namespace
}  // namespace rs
