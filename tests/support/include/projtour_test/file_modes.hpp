#pragma once
// Root writes and reads through a file's mode bits (CAP_DAC_OVERRIDE, CAP_DAC_READ_SEARCH,
// CAP_FOWNER), and CI runs as root: a test of a read-only or unreadable file gives those up so
// that the modes it sets bind, as they would for the robot's own user.
#include <optional>
#include <string>
#include <vector>

namespace projtour::test {

// Gives up the capabilities that override file modes in this process, for good (call it in a
// forked child). True when file modes now bind it (always, for a user other than root).
bool give_up_file_mode_override();

// `argv` to be run with file modes binding: unchanged for a user other than root; as root,
// through util-linux's setpriv without those capabilities (nor, across exec, in the bounding
// set). nullopt when root and setpriv cannot do it here (why in `why`).
std::optional<std::vector<std::string>> with_file_modes_binding(std::vector<std::string> argv,
                                                                std::string& why);

}  // namespace projtour::test
