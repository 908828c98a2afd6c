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
          blocked: defer_target   # someone or something in the way: come back later
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
        retries: 2          # re-aims after a poor or missing fit, or with the aligned pose
        on:
          succeeded: capture
          out_of_reach: skip_target
          reapproach: [navigate, skip_target]   # the content fits only from the true stand-off
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
          succeeded: calibrate
          poor_fit: [capture, aim, skip_target]
          no_target: [aim, skip_target]
          failed: skip_target
      calibrate:            # structured light: the camera-projector calibration, measured here
        behaviour: calibrate
        retries: 2
        on:
          succeeded: verify
          off_screen: [aim, skip_target]          # re-aim with the aligned pose
          too_few_points: [capture, verify]       # else verify with the calibration believed so far
          poor_fit: [capture, verify]
          no_frame: [calibrate, verify]
          blocked_beam: [wait, skip_target]       # someone in the structured light
          occluded: [wait, skip_target]           # something stood in the beam at capture
          failed: skip_target
      verify:               # the colour camera: where the corners land, and the beam is clear
        behaviour: verify
        retries: 3
        on:
          verified: project
          out_of_tolerance: [calibrate, skip_target]
          uncertain: skip_target                  # a rough model: no check can vouch for it
          misaligned: [verify, skip_target]       # the outline slid the pose; look again
          not_seen: [capture, skip_target]
          occluded: [wait, skip_target]
          off_screen: [aim, skip_target]
          no_frame: [verify, skip_target]
          blocked_beam: [wait, defer_target]      # someone in the beam: wait, then come back later
          failed: skip_target
      wait:                 # for the beam to clear
        behaviour: wait
        retries: 2          # five seconds each (wait's default duration_s)
        on:
          succeeded: verify
          failed: skip_target
      project:
        behaviour: project
        projected_on: succeeded   # only reached through verify's gate
        on:
          succeeded: next
          off_screen: [aim, skip_target]
          blocked_beam: defer_target              # someone stood in the light: come back later
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
