#pragma once
// `projtour localize --map M --rawlog R (--init X,Y,YAW_DEG | --score T.tum) [--particles N]
//  [--seed S] [--field boundary|occupied] [--truth GT] [--from-scan K] [--out T.tum]`: the
// tour's localization filter over a recorded MRPT rawlog, one TUM line (timestamp x y z qx qy qz
// qw) per laser scan. How a user checks a map against a drive: it reports the share of scan
// endpoints within 0.1 m of a wall face from scan K on, and with --truth (MRPT's "t x y phi" or
// TUM) the ATE. --score T.tum scores another localizer's trajectory the same way instead of
// running the filter.

namespace projtour {

// argv[0] is "localize". Returns the process exit status (0 done, 2 invalid input, 1 failure).
int run_localize_command(int argc, char** argv);

}  // namespace projtour
