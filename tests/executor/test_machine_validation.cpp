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
  Diagnostics diag;
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
