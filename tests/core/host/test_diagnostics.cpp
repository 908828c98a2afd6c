#include <gtest/gtest.h>

#include "projtour/host/diagnostics.hpp"
#include "projtour/host/yaml_reader.hpp"

using namespace projtour;

TEST(Diagnostics, FormatsFileLineColumnFieldAndMessage) {
  host::Diagnostic d{host::Severity::error,
                     {"m.yaml", 3, 14},
                     "targets[2].pose.yaw_deg",
                     "expected a number, got \"north\""};
  EXPECT_EQ(d.format(), "m.yaml:3:14: targets[2].pose.yaw_deg: expected a number, got \"north\"");
}

// A key or value in a file can hold an escape sequence; quoted raw it would drive the terminal.
TEST(Diagnostics, ControlCharacterInAFieldNameEscaped) {
  host::Diagnostics diag;
  const auto node = host::load_yaml_string("\"sta\\e[2Jrt\\n\": 1\n", "m.yaml", diag);
  ASSERT_TRUE(node);
  host::YamlField root(*node, "m.yaml", diag);
  root.check_keys({"start"});
  ASSERT_EQ(diag.items().size(), 1u);
  EXPECT_EQ(diag.items()[0].format(),
            "m.yaml:1:1: sta\\x1b[2Jrt\\n: unknown key \"sta\\x1b[2Jrt\\n\"");
}

TEST(Diagnostics, DeleteC1ControlsAndInvalidUtf8EscapedOtherScriptsKept) {
  host::Diagnostic d{host::Severity::error, {"m\x7f.yaml", 1, 1}, "", ""};
  d.message = "tab\there \xc2\x9b[31m \xff\xc0\xaf \xe2\x82 \xed\xa0\x80 caf\xc3\xa9 \xe6\x97\xa5";
  EXPECT_EQ(d.format(),
            "m\\x7f.yaml:1:1: tab\\there \\u009b[31m \\xff\\xc0\\xaf \\xe2\\x82 "
            "\\xed\\xa0\\x80 caf\xc3\xa9 \xe6\x97\xa5");
}

TEST(YamlField, WrongTypeNamesFieldAndPosition) {
  host::Diagnostics diag;
  const auto node = host::load_yaml_string("pose:\n  yaw_deg: north\n", "m.yaml", diag);
  ASSERT_TRUE(node);
  host::YamlField root(*node, "m.yaml", diag);
  EXPECT_FALSE(root["pose"]["yaw_deg"].as_double());
  ASSERT_EQ(diag.items().size(), 1u);
  EXPECT_EQ(diag.items()[0].format(),
            "m.yaml:2:12: pose.yaw_deg: expected a number, got \"north\"");
}

TEST(YamlField, MissingKeyReportsParentMark) {
  host::Diagnostics diag;
  const auto node = host::load_yaml_string("a: 1\npose:\n  x: 2\n", "m.yaml", diag);
  host::YamlField root(*node, "m.yaml", diag);
  EXPECT_FALSE(root["pose"]["y"].as_double());
  ASSERT_EQ(diag.items().size(), 1u);
  EXPECT_EQ(diag.items()[0].format(), "m.yaml:3:3: pose.y: missing required field");
}

TEST(YamlField, UnknownKeySuggestsClosest) {
  host::Diagnostics diag;
  const auto node = host::load_yaml_string("standof_m: 1\n", "m.yaml", diag);
  host::YamlField root(*node, "m.yaml", diag);
  root.check_keys({"standoff_m", "dwell_s"});
  ASSERT_EQ(diag.items().size(), 1u);
  EXPECT_EQ(diag.items()[0].format(),
            "m.yaml:1:1: standof_m: unknown key \"standof_m\"; did you mean \"standoff_m\"?");
}
