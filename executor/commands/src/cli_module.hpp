#pragma once
// The projtour command is a small launcher (main.cpp) and this module, which it dlopens: the
// module holds every command but `history`, and with them the robot's libraries (PCL, VTK, MRPT,
// OpenCV, Cyclone DDS: some 350 shared libraries, half a second to load and relocate), which
// `projtour history`, run from scripts and dashboards, never needs.
//
// The launcher finds the module only beside itself, at one of these paths relative to its own
// directory (never a search path nor the environment), as it finds its libraries.

// The module's one exported symbol: `main` for every command but history.
extern "C" __attribute__((visibility("default"))) int projtour_cli_main(int argc, char** argv);
using ProjtourCliMain = int (*)(int, char**);
inline constexpr const char* kProjtourCliMainSymbol = "projtour_cli_main";
