#pragma once
// The faults a dry run can inject (world file `faults`), defined once: each type's name, its
// numbers with their sign, default, unit and meaning, and what the fault does. The world loader
// checks a world file against this table; the simulator takes every default from it. It lives in
// the host because the host reads world files and the simulator links the host, never the other
// way round (core/host must not link a plugin).
#include <string>
#include <vector>

#include "projtour/host/world.hpp"

namespace projtour::host {

// What a fault number may be; the loader says so at the number's file:line:col.
enum class FaultNumberSign { any, positive, non_negative };

struct FaultNumberSpec {
  const char* key;  // as written in the world file, unit in the name (distance_m, after_s)
  FaultNumberSign sign;
  double default_value;  // what the simulator uses when the world file leaves it out
  const char* meaning;
};

struct FaultKindSpec {
  const char* type;
  std::vector<FaultNumberSpec> numbers;  // in the order the loader lists them
  const char* what;                      // what the simulator does (one line)
};

// Every fault type, in the order the loader lists them in its diagnostics.
const std::vector<FaultKindSpec>& fault_kinds();
// The type's entry, or nullptr when there is no such type.
const FaultKindSpec* find_fault_kind(const std::string& type);
// The table's default for a number of the type; throws std::logic_error when the table has no
// such number (a simulator reading a key the loader would refuse).
double fault_default(const std::string& type, const std::string& key);
// The fault's number as written, else the table's default for its type.
double fault_number(const FaultSpec& fault, const std::string& key);

}  // namespace projtour::host
