// Machine validation: every problem with its exact file:line:column and field path.
#include <gtest/gtest.h>

#include "executor_harness.hpp"

namespace projtour::testing {
namespace {

// A for_each with one leaf `a` whose state body is `body` (indented to sit under `a:`).
std::string machine_with(const std::string& body, const std::string& more_states = "") {
  return "initial: visit\n"        // 1
         "states:\n"               // 2
         "  visit:\n"              // 3
         "    for_each: target\n"  // 4
         "    initial: a\n"        // 5
         "    states:\n"           // 6
         "      a:\n" +            // 7
         body +
         more_states +  // 8..
         "    on: {done: finish}\n";
}

std::vector<std::string> errors_of(const std::string& yaml) {
  Harness h;
  host::Diagnostics diag;
  const auto machine = h.parse(yaml, diag);
  EXPECT_FALSE(machine.has_value());
  std::vector<std::string> out;
  for (const auto& d : diag.items()) out.push_back(d.format());
  return out;
}

TEST(MachineValidation, UnreachableState) {
  const auto errors =
      errors_of(machine_with("        behaviour: scripted\n"
                             "        on: {succeeded: finish, failed: skip_target}\n",
                             "      orphan:\n"
                             "        behaviour: scripted\n"
                             "        on: {succeeded: a, failed: skip_target}\n"));
  EXPECT_EQ(errors, std::vector<std::string>{
                        "machine.yaml:10:7: states.visit.states.orphan: state \"orphan\" is "
                        "unreachable from initial state \"a\""});
}

TEST(MachineValidation, DeclaredOutcomeWithoutTransition) {
  const auto errors =
      errors_of(machine_with("        behaviour: navigate\n"
                             "        on: {succeeded: finish, failed: skip_target}\n"));
  const std::string where = "machine.yaml:9:13: states.visit.states.a.on: ";
  EXPECT_EQ(errors,
            (std::vector<std::string>{
                where + "outcome \"unreachable\" of behaviour \"navigate\" has no transition",
                where + "outcome \"blocked\" of behaviour \"navigate\" has no transition",
                where + "outcome \"timeout\" of behaviour \"navigate\" has no transition",
                where + "outcome \"lost\" of behaviour \"navigate\" has no transition"}));
}

TEST(MachineValidation, FailedMustBeHandled) {
  const auto errors =
      errors_of(machine_with("        behaviour: scripted\n"
                             "        on: {succeeded: finish}\n"));
  EXPECT_EQ(errors, std::vector<std::string>{
                        "machine.yaml:9:13: states.visit.states.a.on: outcome \"failed\" of "
                        "behaviour \"scripted\" has no transition"});
}

TEST(MachineValidation, TransitionToUnknownState) {
  const auto errors =
      errors_of(machine_with("        behaviour: scripted\n"
                             "        on: {succeeded: fnish, failed: skip_target}\n"));
  EXPECT_EQ(errors, std::vector<std::string>{
                        "machine.yaml:9:25: states.visit.states.a.on.succeeded: transition to "
                        "unknown state \"fnish\"; did you mean \"finish\"?"});
}

TEST(MachineValidation, UnknownStateInsideARetryList) {
  const auto errors =
      errors_of(machine_with("        behaviour: scripted\n"
                             "        on:\n"
                             "          succeeded: finish\n"
                             "          failed: [a, b, skip_target]\n"));
  EXPECT_EQ(errors, std::vector<std::string>{
                        "machine.yaml:11:23: states.visit.states.a.on.failed[1]: transition to "
                        "unknown state \"b\""});
}

TEST(MachineValidation, TransitionOnUndeclaredOutcome) {
  const auto errors = errors_of(
      machine_with("        behaviour: scripted\n"
                   "        on: {succeeded: finish, failed: skip_target, poor_fit: finish}\n"));
  EXPECT_EQ(errors, std::vector<std::string>{
                        "machine.yaml:9:54: states.visit.states.a.on.poor_fit: behaviour "
                        "\"scripted\" does not declare outcome \"poor_fit\" (it declares: "
                        "succeeded)"});
}

TEST(MachineValidation, TimeoutNeedsTimeoutSeconds) {
  const auto errors = errors_of(
      machine_with("        behaviour: scripted\n"
                   "        on: {succeeded: finish, failed: skip_target, timeout: skip_target}\n"));
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_NE(errors[0].find("machine.yaml:9:54: states.visit.states.a.on.timeout: "),
            std::string::npos);
  EXPECT_NE(errors[0].find("set timeout_s to use \"timeout\""), std::string::npos);
}

TEST(MachineValidation, UnknownBehaviourKindWithSuggestion) {
  const auto errors =
      errors_of(machine_with("        behaviour: scriptd\n"
                             "        on: {succeeded: finish, failed: skip_target}\n"));
  EXPECT_EQ(errors, std::vector<std::string>{
                        "machine.yaml:8:20: states.visit.states.a.behaviour: unknown behaviour "
                        "kind \"scriptd\"; did you mean \"scripted\"?"});
}

TEST(MachineValidation, ParamsCheckedAgainstTheKindsSchemaAndValidate) {
  auto errors =
      errors_of(machine_with("        behaviour: scripted\n"
                             "        params: {ticks: many, outcomez: x}\n"
                             "        on: {succeeded: finish, failed: skip_target}\n"));
  ASSERT_EQ(errors.size(), 2u);
  EXPECT_EQ(errors[0],
            "machine.yaml:9:31: states.visit.states.a.params.outcomez: unknown key \"outcomez\"; "
            "did you mean \"outcomes\"?");
  EXPECT_NE(errors[1].find("machine.yaml:9:25: states.visit.states.a.params.ticks: "),
            std::string::npos);
  errors =
      errors_of(machine_with("        behaviour: scripted\n"
                             "        params: {ticks: 0}\n"
                             "        on: {succeeded: finish, failed: skip_target}\n"));
  EXPECT_EQ(errors, std::vector<std::string>{"machine.yaml:9:17: states.visit.states.a.params: "
                                             "ticks must be at least 1"});
}

TEST(MachineValidation, SkipTargetOutsideForEach) {
  const auto errors = errors_of(
      "initial: a\n"
      "states:\n"
      "  a:\n"
      "    behaviour: scripted\n"
      "    on: {succeeded: finish, failed: skip_target}\n");
  EXPECT_EQ(errors, std::vector<std::string>{"machine.yaml:5:37: states.a.on.failed: "
                                             "skip_target outside a for_each: target state"});
}

// Reachability is not judged from an initial state that does not exist.
TEST(MachineValidation, CompositeNeedsDoneAndAKnownInitial) {
  const auto errors = errors_of(
      "initial: outer\n"
      "states:\n"
      "  outer:\n"
      "    initial: inner\n"
      "    states:\n"
      "      iner:\n"
      "        behaviour: scripted\n"
      "        on: {succeeded: finish, failed: abort}\n");
  EXPECT_EQ(errors, (std::vector<std::string>{
                        "machine.yaml:4:14: states.outer.initial: initial state \"inner\" is not "
                        "among the states; did you mean \"iner\"?",
                        "machine.yaml:3:3: states.outer: composite state \"outer\" has no "
                        "transition for \"done\""}));
}

TEST(MachineValidation, EveryProblemIsReported) {
  const auto errors =
      errors_of(machine_with("        behaviour: scriptd\n"
                             "        on: {succeeded: fnish, failed: skip_target}\n",
                             "      orphan:\n"
                             "        behaviour: scripted\n"
                             "        on: {succeeded: a}\n"));
  EXPECT_EQ(errors.size(), 4u);  // kind, unknown target, failed unhandled, unreachable
}

TEST(MachineValidation, SelfLoopRefused) {
  const auto errors =
      errors_of(machine_with("        behaviour: scripted\n"
                             "        on: {succeeded: a, failed: skip_target}\n"));
  EXPECT_EQ(errors, std::vector<std::string>{
                        "machine.yaml:9:14: states.visit.states.a.on.succeeded: the plain "
                        "transitions visit/a -> visit/a form a cycle that can repeat forever; "
                        "make one of them a retry list (e.g. [visit/a, skip_target]) so retries "
                        "bound it, and give the cycle a way out on an outcome other than "
                        "\"failed\""});
}

TEST(MachineValidation, CycleWhoseOnlyExitIsFailedRefused) {
  const auto errors =
      errors_of(machine_with("        behaviour: scripted\n"
                             "        on: {succeeded: b, failed: skip_target}\n",
                             "      b:\n"
                             "        behaviour: scripted\n"
                             "        on: {succeeded: a, failed: skip_target}\n"));
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(errors[0].rfind("machine.yaml:9:14: states.visit.states.a.on.succeeded: the plain "
                            "transitions visit/a -> visit/b -> visit/a form a cycle",
                            0),
            0u)
      << errors[0];
  EXPECT_NE(errors[0].find("a way out on an outcome other than \"failed\""), std::string::npos);
}

// A plain cycle through `failed` repeats as long as the behaviours keep failing.
TEST(MachineValidation, CycleOfFailedTransitionsRefused) {
  const auto errors =
      errors_of(machine_with("        behaviour: scripted\n"
                             "        on: {succeeded: finish, failed: b}\n",
                             "      b:\n"
                             "        behaviour: scripted\n"
                             "        on: {succeeded: finish, failed: a}\n"));
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(errors[0].rfind("machine.yaml:9:33: states.visit.states.a.on.failed: the plain "
                            "transitions visit/a -> visit/b -> visit/a form a cycle that can "
                            "repeat forever; make one of them a retry list (e.g. [visit/b, "
                            "skip_target]) so retries bound it",
                            0),
            0u)
      << errors[0];
  EXPECT_EQ(errors[0].find("other than \"failed\""), std::string::npos) << errors[0];
}

// Completing a composite takes its `done`: a done leading back into it closes a cycle too.
TEST(MachineValidation, CycleThroughACompositesDoneRefused) {
  const auto errors = errors_of(
      "initial: visit\n"
      "states:\n"
      "  visit:\n"
      "    for_each: target\n"
      "    initial: inner\n"
      "    states:\n"
      "      inner:\n"
      "        initial: a\n"
      "        states:\n"
      "          a:\n"
      "            behaviour: scripted\n"
      "            on: {succeeded: finish, failed: skip_target}\n"
      "        on: {done: inner}\n"
      "    on: {done: finish}\n");
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(errors[0].rfind("machine.yaml:13:14: states.visit.states.inner.on.done: the plain "
                            "transitions visit/inner (done) -> visit/inner -> visit/inner/a -> "
                            "visit/inner (done) form a cycle",
                            0),
            0u)
      << errors[0];
}

TEST(MachineValidation, CycleThroughARetryListAccepted) {
  Harness h;
  host::Diagnostics diag;
  const auto machine =
      h.parse(machine_with("        behaviour: scripted\n"
                           "        retries: 3\n"
                           "        on: {succeeded: b, failed: skip_target}\n",
                           "      b:\n"
                           "        behaviour: scripted\n"
                           "        on: {succeeded: [a, finish], failed: skip_target}\n"),
              diag);
  EXPECT_TRUE(machine.has_value()) << diag.format();
}

// A kind that declares no outcome of its own can only fail.
TEST(MachineValidation, StateWhoseEveryWayOutIsFailedRefused) {
  Harness h;
  h.catalog.add("doomed", {}, {}, nullptr);
  host::Diagnostics diag;
  EXPECT_FALSE(h.parse(machine_with("        behaviour: doomed\n"
                                    "        on: {failed: skip_target}\n"),
                       diag));
  ASSERT_EQ(diag.items().size(), 1u);
  EXPECT_EQ(diag.items()[0].format(),
            "machine.yaml:7:7: states.visit.states.a: every way out of \"visit/a\" is "
            "\"failed\": it needs a transition on another outcome that leads to finish, "
            "skip_target, defer_target or abort");
}

TEST(MachineValidation, RetriesOfABillionRefused) {
  const auto errors =
      errors_of(machine_with("        behaviour: scripted\n"
                             "        retries: 1000000000\n"
                             "        on: {succeeded: [a, finish], failed: skip_target}\n"));
  EXPECT_EQ(errors, std::vector<std::string>{"machine.yaml:9:18: states.visit.states.a.retries: "
                                             "expected a count from 0 to 100"});
}

TEST(MachineValidation, MachineThatNeverVisitsTargetsRefused) {
  Harness h;
  host::Diagnostics diag;
  const std::string yaml =
      "initial: a\n"
      "states:\n"
      "  a:\n"
      "    behaviour: scripted\n"
      "    on: {succeeded: finish, failed: abort}\n";
  const auto node = host::load_yaml_string(yaml, "machine.yaml", diag);
  ASSERT_TRUE(node);
  EXPECT_TRUE(h.parse(yaml, diag)) << diag.format();  // a machine of its own may do without
  host::MachineSource source;
  source.is_default = false;
  source.node = *node;
  source.file = "machine.yaml";
  EXPECT_FALSE(load_machine(source, h.catalog, diag));
  ASSERT_EQ(diag.items().size(), 1u);
  EXPECT_EQ(diag.items()[0].format(),
            "machine.yaml:3:3: states: no state is a for_each: target state, so the mission's "
            "targets would never be visited");
}

TEST(MachineValidation, DuplicateKeyInMachineRefused) {
  const auto errors =
      errors_of(machine_with("        behaviour: scripted\n"
                             "        on: {succeeded: finish, failed: skip_target}\n",
                             "      a:\n"
                             "        behaviour: scripted\n"
                             "        params: {ticks: 2, ticks: 3}\n"
                             "        on: {succeeded: finish, failed: skip_target}\n"));
  EXPECT_EQ(errors, (std::vector<std::string>{
                        "machine.yaml:10:7: states.visit.states.a: duplicate key \"a\" (first at "
                        "line 7)",
                        "machine.yaml:12:28: states.visit.states.a.params.ticks: duplicate key "
                        "\"ticks\" (first at line 12)"}));
}

// Aliases let a few lines name a billion states; the count is bounded before they are read.
TEST(MachineValidation, AliasesCannotMultiplyStatesPastTheBound) {
  std::string yaml =
      "initial: visit\n"
      "states:\n"
      "  visit:\n"
      "    for_each: target\n"
      "    initial: s0\n"
      "    states:\n"
      "      s0: &l0 {behaviour: scripted, on: {succeeded: finish, failed: skip_target}}\n";
  std::string level = "l0";
  for (int depth = 1; depth <= 9; ++depth) {
    const std::string name = "l" + std::to_string(depth);
    yaml += "      s" + std::to_string(depth) + ": &" + name + " {initial: a, states: {";
    for (const char* child : {"a", "b", "c", "d", "e", "f", "g", "h", "i", "j"}) {
      yaml += std::string(child) + ": *" + level + ", ";
    }
    yaml += "}, on: {done: finish}}\n";
    level = name;
  }
  yaml += "    on: {done: finish}\n";
  const auto errors = errors_of(yaml);
  ASSERT_FALSE(errors.empty());
  EXPECT_NE(errors[0].find("more than 1000 states in one machine"), std::string::npos) << errors[0];
}

TEST(MachineValidation, DefaultMachineIsValidAndDrawsClusters) {
  Harness h;
  h.load_default();
  ASSERT_TRUE(h.machine.has_value());
  EXPECT_EQ(h.machine->leaves().size(), 10u);
  const StateSpec* align = h.machine->find("tour/visit/align");
  ASSERT_NE(align, nullptr);
  ASSERT_NE(align->transition("poor_fit"), nullptr);
  EXPECT_EQ(align->transition("poor_fit")->targets,
            (std::vector<std::string>{"capture", "aim", "skip_target"}));
  const std::string dot = machine_to_dot(*h.machine);
  EXPECT_EQ(dot.rfind("digraph machine {", 0), 0u);
  EXPECT_NE(dot.find("subgraph \"cluster_tour\""), std::string::npos);
  EXPECT_NE(dot.find("subgraph \"cluster_tour/visit\""), std::string::npos);
  EXPECT_NE(dot.find("label=\"visit (for each target)\""), std::string::npos);
  EXPECT_NE(dot.find("\"tour/visit/align\" -> \"tour/visit/capture\" [label=\"poor_fit\"]"),
            std::string::npos);
  EXPECT_NE(dot.find("\"tour/visit/align\" -> \"tour/visit/skip_target\""), std::string::npos);
}

}  // namespace
}  // namespace projtour::testing
