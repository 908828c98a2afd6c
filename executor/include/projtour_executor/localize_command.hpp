#pragma once
// `projtour localize --map M --rawlog R --init X,Y,YAW_DEG [--particles N] [--seed S]
//  [--out T.tum]`: the tour's localization filter over a recorded MRPT rawlog, one TUM line
// (timestamp x y z qx qy qz qw) per laser scan. How a user checks a map against a drive.

namespace projtour {

// argv[0] is "localize". Returns the process exit status (0 done, 2 invalid input, 1 failure).
int run_localize_command(int argc, char** argv);

}  // namespace projtour
