// The default tour of DESIGN.md, written in the same YAML a mission may use to replace it.
#include "projtour_executor/machine.hpp"

namespace projtour {

const std::string& default_machine_yaml() {
  static const std::string kText = R"(name: tour
initial: visit
states:
  visit:
    for_each: target        # order: mission | nearest (default: the mission's order)
    initial: navigate
    states:
      navigate:
        behaviour: navigate
        retries: 2          # re-entries after relocalizing
        on:
          succeeded: aim
          unreachable: skip_target
          blocked: skip_target
          timeout: skip_target
          lost: relocalize
          failed: skip_target
      relocalize:
        behaviour: relocalize
        on:
          succeeded: [navigate, skip_target]
          lost: skip_target
          failed: skip_target
      aim:
        behaviour: aim
        retries: 1          # one re-aim after a poor or missing fit
        on:
          succeeded: capture
          out_of_reach: skip_target
          failed: skip_target
      capture:
        behaviour: capture
        retries: 2          # re-captures after a dropped frame or a poor fit
        on:
          succeeded: align
          no_frame: [capture, skip_target]
          failed: skip_target
      align:
        behaviour: align
        on:
          succeeded: project
          poor_fit: [capture, aim, skip_target]
          no_target: [aim, skip_target]
          failed: skip_target
      project:
        behaviour: project
        projected_on: succeeded   # the visit counts as shown once project succeeds
        on:
          succeeded: next
          off_screen: skip_target
          failed: skip_target
      next:
        behaviour: next
        on:
          succeeded: finish
          failed: skip_target
    on:
      done: done
  done:
    final: true
)";
  return kText;
}

}  // namespace projtour
