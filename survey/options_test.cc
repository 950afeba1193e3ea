#include "survey/options.h"

#include <gtest/gtest.h>

namespace rs {
namespace {

struct DemoOptions {
  int max_disparity = 64;      // widest disparity
  double p1 = 8.0;             // small-change penalty
  double p2 = 32.0;            // large-change penalty
  bool lr_check = true;        // left-right consistency
  std::string method = "sgm";  // algorithm

  void Check() const {
    CheckRule(p2 > p1, "demo", "p2", p2, "p2 > p1", "p1 = " + std::to_string(static_cast<int>(p1)));
  }
  static const OptionTable<DemoOptions>& Table() {
    static const auto table = OptionTable<DemoOptions>()
                                  .Add("max_disparity", &DemoOptions::max_disparity, "widest disparity", "px")
                                  .Min(1)
                                  .Max(512)
                                  .Add("p1", &DemoOptions::p1, "small-change penalty")
                                  .Above(0)
                                  .Add("p2", &DemoOptions::p2, "large-change penalty")
                                  .Add("lr_check", &DemoOptions::lr_check, "left-right consistency")
                                  .Add("method", &DemoOptions::method, "algorithm")
                                  .OneOf({"sgm", "gpt-sgm"});
    return table;
  }
};

TEST(OptionTable, Nominal) {
  const auto& t = DemoOptions::Table();
  const auto merged = t.Merge({{"max_disparity", 128}, {"p2", 40}}, "demo");
  const DemoOptions o = t.FromJson(merged);
  EXPECT_EQ(o.max_disparity, 128);
  EXPECT_DOUBLE_EQ(o.p2, 40.0);
  EXPECT_TRUE(merged["p2"].is_number_float()) << "doubles stay doubles so cache keys are canonical";
  EXPECT_EQ(t.ToJson(o), merged);
  EXPECT_EQ(t.Defaults()["method"], "sgm");
}

TEST(OptionTable, UnknownKeyNamesKeyAndKnownOnes) {
  try {
    DemoOptions::Table().Merge({{"max_disparty", 3}}, "demo");
    FAIL();
  } catch (const OptionError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("demo.max_disparty: unknown option"), std::string::npos) << what;
    EXPECT_NE(what.find("max_disparity"), std::string::npos) << what;
  }
}

TEST(OptionTable, IllTypedAndOutOfRange) {
  const auto& t = DemoOptions::Table();
  EXPECT_THROW(t.Merge({{"max_disparity", "wide"}}, "demo"), OptionError);
  EXPECT_THROW(t.Merge({{"max_disparity", 1.5}}, "demo"), OptionError);
  EXPECT_THROW(t.Merge({{"lr_check", 1}}, "demo"), OptionError);
  try {
    t.Merge({{"max_disparity", 0}}, "demo");
    FAIL();
  } catch (const OptionError& e) {
    EXPECT_STREQ(e.what(), "demo.max_disparity = 0: expected integer >= 1 <= 512");
  }
  try {
    t.Merge({{"method", "bm"}}, "demo");
    FAIL();
  } catch (const OptionError& e) {
    EXPECT_STREQ(e.what(), "demo.method = \"bm\": expected one of {sgm, gpt-sgm}");
  }
}

TEST(OptionTable, CheckStatesRule) {
  DemoOptions o;
  o.p2 = 5;
  try {
    o.Check();
    FAIL();
  } catch (const OptionError& e) {
    EXPECT_STREQ(e.what(), "demo.p2 = 5.0 violates p2 > p1 (p1 = 8)");
  }
}

enum class Mode { kFast, kExact };
struct Inner {
  int window = 5;  // window size
  static const OptionTable<Inner>& Table() {
    static const auto t = OptionTable<Inner>().Add("window", &Inner::window, "window size").Min(3);
    return t;
  }
};
struct Outer {
  Mode mode = Mode::kExact;
  Inner inner;
  static const OptionTable<Outer>& Table() {
    static const auto t = OptionTable<Outer>()
                              .AddEnum("mode", &Outer::mode, {{"fast", Mode::kFast}, {"exact", Mode::kExact}}, "mode")
                              .Include("inner", &Outer::inner, Inner::Table());
    return t;
  }
};

TEST(OptionTable, EnumsAndNestedStructs) {
  const auto& t = Outer::Table();
  EXPECT_EQ(t.Defaults(), nlohmann::json({{"mode", "exact"}, {"inner.window", 5}}));
  const Outer o = t.FromJson(t.Merge({{"mode", "fast"}, {"inner.window", 9}}, "outer"));
  EXPECT_EQ(o.mode, Mode::kFast);
  EXPECT_EQ(o.inner.window, 9);
  EXPECT_EQ(t.ToJson(o)["mode"], "fast");
  EXPECT_THROW(t.Merge({{"inner.window", 1}}, "outer"), OptionError) << "nested bounds still apply";
  EXPECT_THROW(t.Merge({{"mode", "slow"}}, "outer"), OptionError);
}

TEST(OptionTable, SchemaCarriesBoundsAndDocs) {
  const auto schema = DemoOptions::Table().Schema("demo stage");
  EXPECT_EQ(schema["additionalProperties"], false);
  EXPECT_EQ(schema["properties"]["max_disparity"]["minimum"], 1);
  EXPECT_EQ(schema["properties"]["max_disparity"]["description"], "widest disparity [px]");
  EXPECT_EQ(schema["properties"]["p1"]["exclusiveMinimum"], 0);
  EXPECT_EQ(schema["properties"]["method"]["enum"].size(), 2u);
}

}  // namespace
}  // namespace rs
