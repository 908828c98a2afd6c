// Typed data between the steps: the blackboard refuses a value of the wrong type, and loading a
// machine checks that every key a state reads is written before it on every path.
#include <gtest/gtest.h>

#include "executor_harness.hpp"
#include "projtour/contract/blackboard_keys.hpp"

namespace projtour::testing {
namespace {

constexpr Key<int> kCount{"count", KeyScope::visit, "int"};
constexpr Key<double> kCountAsDouble{"count", KeyScope::visit, "double"};
constexpr Key<int> kTourCount{"tour.count", KeyScope::tour, "int"};

TEST(Blackboard, FindsWhatWasSetWithoutCopyingAndRefusesAnotherType) {
  Blackboard bb;
  EXPECT_EQ(bb.find(kCount), nullptr);
  bb.set(kCount, 3);
  const int* first = bb.find(kCount);
  ASSERT_NE(first, nullptr);
  EXPECT_EQ(*first, 3);
  EXPECT_EQ(bb.find(kCount), first);  // the stored value itself, no copy
  EXPECT_THROW(bb.set(kCountAsDouble, 1.5), BlackboardTypeError);
  try {
    bb.find(kCountAsDouble);
    FAIL() << "read an int as a double";
  } catch (const BlackboardTypeError& e) {
    EXPECT_STREQ(e.what(), "blackboard key \"count\" holds a int, not a double");
  }
  EXPECT_EQ(*bb.find(kCount), 3);  // the refused write changed nothing
}

TEST(Blackboard, ANewVisitClearsVisitKeysOnlyAndVersionsTellWhatWasWritten) {
  Blackboard bb;
  bb.set(kCount, 1);
  bb.set(kTourCount, 1);
  const std::uint64_t before = bb.writes();
  EXPECT_LE(bb.version(kCount), before);
  bb.set(kCount, 2);
  EXPECT_GT(bb.version(kCount), before);
  EXPECT_LE(bb.version(kTourCount), before);
  bb.clear_visit();
  EXPECT_FALSE(bb.has(kCount));
  EXPECT_TRUE(bb.has(kTourCount));
  EXPECT_EQ(bb.version(kCount), 0u);
}

// A catalog whose kinds declare keys: `make` writes "frame", `use` reads it, `peek` reads it
// only if present, `other` writes "frame" as another type.
class DataHarness {
 public:
  DataHarness() {
    const auto none = [](const Params&, const RunContext&) -> std::shared_ptr<Behaviour> {
      return nullptr;
    };
    catalog.add("make", {"succeeded", "nothing"}, {}, none, nullptr,
                {{"frame", "CapturedFrame", host::KeyAccess::write}});
    catalog.add("use", {"succeeded"}, {}, none, nullptr,
                {{"frame", "CapturedFrame", host::KeyAccess::read}});
    catalog.add("peek", {"succeeded"}, {}, none, nullptr,
                {{"frame", "CapturedFrame", host::KeyAccess::read_if_present}});
    catalog.add("other", {"succeeded"}, {}, none, nullptr,
                {{"frame", "DepthFrame", host::KeyAccess::write}});
    catalog.add("locate", {"succeeded"}, {}, none, nullptr,
                {{"localization.estimate", "PoseEstimate2D", host::KeyAccess::read}});
  }

  std::vector<std::string> errors(const std::string& yaml,
                                  const std::vector<host::KeyUse>& services = {}) {
    host::Diagnostics diag;
    const auto node = host::load_yaml_string(yaml, "machine.yaml", diag);
    const auto machine = load_machine(host::YamlField(*node, "machine.yaml", diag), catalog, diag);
    EXPECT_TRUE(machine.has_value()) << diag.format();
    if (machine) check_machine_data(*machine, catalog, services, diag);
    std::vector<std::string> out;
    for (const auto& d : diag.items()) out.push_back(d.format());
    return out;
  }

  InProcessCatalog catalog;
};

// `a` -> `b` -> finish in a for_each; `b` is reached only after `a` succeeded.
std::string visit(const std::string& a, const std::string& a_on, const std::string& b) {
  return "initial: visit\n"        // 1
         "states:\n"               // 2
         "  visit:\n"              // 3
         "    for_each: target\n"  // 4
         "    initial: a\n"        // 5
         "    states:\n"           // 6
         "      a:\n"              // 7
         "        behaviour: " +
         a +
         "\n"  // 8
         "        on: " +
         a_on +
         "\n"          // 9
         "      b:\n"  // 10
         "        behaviour: " +
         b +
         "\n"  // 11
         "        on: {succeeded: finish, failed: skip_target}\n"
         "    on: {done: finish}\n";
}

TEST(MachineData, AReadWrittenBeforeOnEveryPathPasses) {
  DataHarness h;
  EXPECT_TRUE(
      h.errors(visit("make", "{succeeded: b, nothing: skip_target, failed: skip_target}", "use"))
          .empty());
}

TEST(MachineData, AReadReachedWhereTheWriterDidNotSucceedIsAnErrorAtTheReader) {
  DataHarness h;
  EXPECT_EQ(h.errors(visit("make", "{succeeded: b, nothing: b, failed: skip_target}", "use")),
            std::vector<std::string>{
                "machine.yaml:10:7: states.visit.states.b.behaviour: behaviour \"use\" reads "
                "\"frame\" (CapturedFrame), which is not written on every path that reaches it "
                "(written by tour/visit/a)"});
}

TEST(MachineData, AReadNobodyWritesNamesThatToo) {
  DataHarness h;
  EXPECT_EQ(h.errors(visit("peek", "{succeeded: b, failed: skip_target}", "use")),
            std::vector<std::string>{
                "machine.yaml:10:7: states.visit.states.b.behaviour: behaviour \"use\" reads "
                "\"frame\" (CapturedFrame), which no state of the machine and no service writes"});
}

// What a visit wrote is gone when the next one starts, so the second visit's `use` has nothing.
TEST(MachineData, AWriteDoesNotCarryIntoTheNextVisit) {
  DataHarness h;
  const std::string yaml =
      "initial: visit\n"
      "states:\n"
      "  visit:\n"
      "    for_each: target\n"
      "    initial: a\n"
      "    states:\n"
      "      a:\n"
      "        behaviour: use\n"
      "        on: {succeeded: b, failed: skip_target}\n"
      "      b:\n"
      "        behaviour: make\n"
      "        on: {succeeded: finish, nothing: finish, failed: skip_target}\n"
      "    on: {done: finish}\n";
  const auto errors = h.errors(yaml);
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(
      errors[0].rfind("machine.yaml:7:7: states.visit.states.a.behaviour: behaviour \"use\"", 0),
      0u)
      << errors[0];
}

TEST(MachineData, AServiceWriteSatisfiesEveryState) {
  DataHarness h;
  const std::string yaml = visit("locate", "{succeeded: b, failed: skip_target}", "peek");
  EXPECT_EQ(h.errors(yaml).size(), 1u);
  EXPECT_TRUE(h.errors(yaml, {{"localization.estimate", "PoseEstimate2D", host::KeyAccess::write}})
                  .empty());
}

TEST(MachineData, ReadersAndWritersOfOneKeyMustAgreeOnItsType) {
  DataHarness h;
  EXPECT_EQ(h.errors(visit("other", "{succeeded: b, failed: skip_target}", "use")),
            std::vector<std::string>{
                "machine.yaml:10:7: states.visit.states.b.behaviour: key \"frame\" is a "
                "\"CapturedFrame\" to behaviour \"use\" (tour/visit/b) but a \"DepthFrame\" to "
                "behaviour \"other\" (tour/visit/a)"});
}

TEST(MachineData, GraphDrawsADottedEdgeFromWriterToReader) {
  DataHarness h;
  host::Diagnostics diag;
  const auto node = host::load_yaml_string(
      visit("make", "{succeeded: b, nothing: skip_target, failed: skip_target}", "use"),
      "machine.yaml", diag);
  const auto machine = load_machine(host::YamlField(*node, "machine.yaml", diag), h.catalog, diag);
  ASSERT_TRUE(machine) << diag.format();
  const std::string dot = machine_to_dot(*machine, &h.catalog);
  EXPECT_NE(dot.find("\"tour/visit/a\" -> \"tour/visit/b\" [label=\"frame\", style=dotted"),
            std::string::npos)
      << dot;
  EXPECT_EQ(machine_to_dot(*machine).find("style=dotted"), std::string::npos);
}

}  // namespace
}  // namespace projtour::testing
