#include "projtour/run/atomic_file.hpp"

#include "projtour/contract/run_files.hpp"

namespace projtour {

void write_file_atomically(const std::filesystem::path& file, const std::string& text) {
  write_run_file(file, text);
}

}  // namespace projtour
