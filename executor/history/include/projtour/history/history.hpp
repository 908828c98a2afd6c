#pragma once
// The proof-of-play history: an embedded SQLite database every run records into (runs, visits,
// a proof image per showing) and `projtour history`, which sums it up (docs/history.md).
//
// The database is not a run file: it lives outside any run directory and is shared by runs and
// robots, so it uses SQLite's own file handling and locking (WAL, a busy timeout), and every
// visit is one transaction.
#include <cstdint>
#include <filesystem>
#include <iosfwd>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

struct sqlite3;

namespace projtour {

// Why a history database could not be used: unreadable, corrupt, read-only, locked past the busy
// timeout, or from a newer projtour. The message names the file.
class HistoryError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The schema version this build writes; HistoryDb migrates older files up to it.
inline constexpr int kHistorySchemaVersion = 1;

// $XDG_DATA_HOME/projtour/history.sqlite, else ~/.local/share/projtour/history.sqlite; empty
// when neither XDG_DATA_HOME nor HOME is set.
std::filesystem::path default_history_path();

// Where a database's proof images go: beside it, `<db>.proofs/`.
std::filesystem::path proofs_dir_of(const std::filesystem::path& db);

struct HistoryRun {
  std::string id;  // a UUID; a resumed run keeps its first invocation's
  std::string mission;
  std::string robot;
  std::string run_dir;
  double started_at_s = 0.0;  // Unix time
  std::optional<double> ended_at_s;
  bool dry_run = false;
  std::uint64_t seed = 1;
  std::string outcome = "running";
};

struct HistoryVisit {
  std::string run_id;
  int round = 0;  // 0 without a schedule
  std::string target;
  std::string content;
  double started_at_s = 0.0;
  double ended_at_s = 0.0;
  double shown_s = 0.0;
  double blanked_s = 0.0;
  std::optional<double> observed_error_mm;
  std::optional<double> true_error_mm;  // a dry run's referee
  std::string outcome;
  std::string reason;
  // The proof image, relative to the database's directory, and the SHA-256 of its bytes.
  std::string proof_path;
  std::string proof_sha256;
};

enum class HistoryAccess { read_only, read_write };

class HistoryDb {
 public:
  // Opens (read_write: creates and migrates) the database; throws HistoryError. A file whose
  // schema version is newer than kHistorySchemaVersion is refused before anything is written.
  HistoryDb(const std::filesystem::path& file, HistoryAccess access, int busy_timeout_ms = 10000);
  ~HistoryDb();
  HistoryDb(const HistoryDb&) = delete;
  HistoryDb& operator=(const HistoryDb&) = delete;

  const std::filesystem::path& file() const { return file_; }
  int schema_version() const;

  // The run whose directory this is, for a resume to reuse its row; nullopt when none.
  std::optional<HistoryRun> find_run_by_dir(const std::string& run_dir) const;
  void upsert_run(const HistoryRun& run);
  // One transaction: the visit (keyed by run, round and target, so a visit resumed or retried is
  // one showing) and the run's row brought up to date.
  void record_visit(const HistoryVisit& visit);
  std::vector<HistoryVisit> visits() const;  // every visit, oldest first
  std::vector<HistoryRun> runs() const;

  sqlite3* handle() const { return db_; }

 private:
  void exec(const std::string& sql) const;
  void migrate();
  std::filesystem::path file_;
  sqlite3* db_ = nullptr;
};

// Writes a proof image (JPEG bytes) into proofs_dir_of(db) named by its hash; returns the path
// relative to the database's directory and the hash's hex. Written once: a file of that name
// already holds those bytes.
struct StoredProof {
  std::string relative_path;
  std::string sha256;
};
StoredProof store_proof(const std::filesystem::path& db, const std::vector<unsigned char>& jpeg);
std::string sha256_hex(const std::vector<unsigned char>& bytes);

// `projtour history`'s query.
struct HistoryQuery {
  std::optional<double> from_s;  // Unix time, inclusive
  std::optional<double> to_s;    // exclusive
  std::optional<std::string> content;
  std::optional<std::string> target;
  std::string by = "content";  // content | target | day | run
  bool include_dry_runs = false;
};

struct HistoryRow {
  std::string key;
  bool dry_run = false;
  int showings = 0;  // visits that projected
  int visits = 0;
  double shown_s = 0.0;
  double blanked_s = 0.0;
  std::optional<double> median_observed_mm;
  std::optional<double> worst_observed_mm;
  std::optional<double> median_true_mm;
  std::optional<double> worst_true_mm;
};

// A showing for the page: its place, time and proof.
struct HistoryShowing {
  std::string day;  // YYYY-MM-DD (UTC)
  std::string content;
  std::string target;
  std::string run_id;
  int round = 0;
  double started_at_s = 0.0;
  double shown_s = 0.0;
  std::optional<double> observed_error_mm;
  std::string proof_path;
  std::string proof_sha256;
};

std::vector<HistoryRow> summarize_history(const HistoryDb& db, const HistoryQuery& query);
std::vector<HistoryShowing> history_showings(const HistoryDb& db, const HistoryQuery& query);

// "2026-03-01" (00:00 UTC) or "2026-03-01T10:30[:00][Z]" (UTC); nullopt when malformed. A date
// alone as `to` means the whole of that day (the caller adds the day).
std::optional<double> parse_history_time(const std::string& text, bool* date_only = nullptr);

// Writes the summary as a table, CSV or JSON; the page (per-content totals, a calendar of
// showings, the proof images) to `html_file`.
void print_history_table(const std::vector<HistoryRow>& rows, const HistoryQuery& query,
                         std::ostream& out);
void print_history_csv(const std::vector<HistoryRow>& rows, std::ostream& out);
void print_history_json(const std::vector<HistoryRow>& rows, const HistoryQuery& query,
                        std::ostream& out);
void write_history_page(const HistoryDb& db, const HistoryQuery& query,
                        const std::filesystem::path& html_file);

// The `projtour history` subcommand (argv[1] == "history"): its exit status.
int history_command(int argc, char** argv, std::ostream& out, std::ostream& err);

}  // namespace projtour
