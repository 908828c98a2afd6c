// The history database (history.hpp): schema, migrations, visits and proofs.
#include "projtour/history/history.hpp"

#include <openssl/evp.h>
#include <sqlite3.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <map>
#include <system_error>

namespace projtour {

namespace {

// Each entry takes the schema from version i to i + 1; version 0 is an empty file. A v2 adds
// its statements as the second entry and raises kHistorySchemaVersion; nothing here is ever
// edited once released, so every older file follows the same steps.
const char* const kMigrations[] = {
    // v0 -> v1
    "CREATE TABLE runs ("
    "  id TEXT PRIMARY KEY,"
    "  mission TEXT NOT NULL,"
    "  robot TEXT NOT NULL,"
    "  run_dir TEXT NOT NULL,"
    "  started_at REAL NOT NULL,"
    "  ended_at REAL,"
    "  dry_run INTEGER NOT NULL CHECK (dry_run IN (0, 1)),"
    "  seed INTEGER NOT NULL,"
    "  outcome TEXT NOT NULL);"
    "CREATE INDEX runs_by_dir ON runs(run_dir);"
    "CREATE TABLE visits ("
    "  run_id TEXT NOT NULL REFERENCES runs(id),"
    "  round INTEGER NOT NULL,"
    "  target TEXT NOT NULL,"
    "  content TEXT NOT NULL,"
    "  started_at REAL NOT NULL,"
    "  ended_at REAL NOT NULL,"
    "  shown_s REAL NOT NULL,"
    "  blanked_s REAL NOT NULL,"
    "  observed_error_mm REAL,"
    "  true_error_mm REAL,"
    "  outcome TEXT NOT NULL,"
    "  reason TEXT NOT NULL,"
    "  PRIMARY KEY (run_id, round, target));"
    "CREATE INDEX visits_by_time ON visits(started_at);"
    "CREATE TABLE proofs ("
    "  run_id TEXT NOT NULL,"
    "  round INTEGER NOT NULL,"
    "  target TEXT NOT NULL,"
    "  path TEXT NOT NULL,"
    "  sha256 TEXT NOT NULL CHECK (length(sha256) = 64),"
    "  PRIMARY KEY (run_id, round, target),"
    "  FOREIGN KEY (run_id, round, target) REFERENCES visits(run_id, round, target));",
};
static_assert(sizeof kMigrations / sizeof kMigrations[0] == kHistorySchemaVersion,
              "one migration per schema version");

// A prepared statement, finalized on every path.
class Statement {
 public:
  Statement(sqlite3* db, const std::string& sql, const std::filesystem::path& file) : db_(db) {
    if (sqlite3_prepare_v2(db, sql.c_str(), -1, &stmt_, nullptr) != SQLITE_OK) {
      throw HistoryError(file.string() + ": " + sqlite3_errmsg(db));
    }
    file_ = file;
  }
  ~Statement() { sqlite3_finalize(stmt_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  void bind(int i, const std::string& s) {
    sqlite3_bind_text(stmt_, i, s.c_str(), static_cast<int>(s.size()), SQLITE_TRANSIENT);
  }
  void bind(int i, double v) { sqlite3_bind_double(stmt_, i, v); }
  void bind(int i, std::int64_t v) { sqlite3_bind_int64(stmt_, i, v); }
  void bind(int i, const std::optional<double>& v) {
    if (v) {
      sqlite3_bind_double(stmt_, i, *v);
    } else {
      sqlite3_bind_null(stmt_, i);
    }
  }
  // true while a row is there.
  bool step() {
    const int rc = sqlite3_step(stmt_);
    if (rc == SQLITE_ROW) return true;
    if (rc == SQLITE_DONE) return false;
    throw HistoryError(describe(rc));
  }
  std::string text(int i) const {
    const unsigned char* t = sqlite3_column_text(stmt_, i);
    return t == nullptr ? std::string() : reinterpret_cast<const char*>(t);
  }
  double real(int i) const { return sqlite3_column_double(stmt_, i); }
  std::int64_t integer(int i) const { return sqlite3_column_int64(stmt_, i); }
  std::optional<double> maybe(int i) const {
    if (sqlite3_column_type(stmt_, i) == SQLITE_NULL) return std::nullopt;
    return real(i);
  }

 private:
  std::string describe(int rc) const {
    std::string what = sqlite3_errmsg(db_);
    if ((rc & 0xff) == SQLITE_BUSY) what = "locked by another writer past the busy timeout";
    if ((rc & 0xff) == SQLITE_READONLY) what = "read-only (" + what + ")";
    return file_.string() + ": " + what;
  }
  sqlite3* db_;
  sqlite3_stmt* stmt_ = nullptr;
  std::filesystem::path file_;
};

// A runs row, from a query of kRunColumns.
const char* const kRunColumns =
    "SELECT id, mission, robot, run_dir, started_at, ended_at, dry_run, seed, outcome FROM runs ";
HistoryRun run_from(const Statement& q) {
  HistoryRun r;
  r.id = q.text(0);
  r.mission = q.text(1);
  r.robot = q.text(2);
  r.run_dir = q.text(3);
  r.started_at_s = q.real(4);
  r.ended_at_s = q.maybe(5);
  r.dry_run = q.integer(6) != 0;
  r.seed = static_cast<std::uint64_t>(q.integer(7));
  r.outcome = q.text(8);
  return r;
}

std::string hex(const unsigned char* bytes, std::size_t n) {
  static const char digits[] = "0123456789abcdef";
  std::string out;
  for (std::size_t i = 0; i < n; ++i) {
    out += digits[bytes[i] >> 4];
    out += digits[bytes[i] & 15];
  }
  return out;
}

}  // namespace

std::filesystem::path default_history_path() {
  const char* xdg = std::getenv("XDG_DATA_HOME");
  // The XDG spec: a relative XDG_DATA_HOME is invalid and ignored.
  if (xdg != nullptr && *xdg == '/') {
    return std::filesystem::path(xdg) / "projtour" / "history.sqlite";
  }
  const char* home = std::getenv("HOME");
  if (home == nullptr || *home == '\0') return {};
  return std::filesystem::path(home) / ".local" / "share" / "projtour" / "history.sqlite";
}

std::filesystem::path proofs_dir_of(const std::filesystem::path& db) {
  return db.parent_path() / (db.filename().string() + ".proofs");
}

HistoryDb::HistoryDb(const std::filesystem::path& file, HistoryAccess access, int busy_timeout_ms)
    : file_(file) {
  const bool write = access == HistoryAccess::read_write;
  if (write && !file.parent_path().empty()) {
    std::error_code ec;
    std::filesystem::create_directories(file.parent_path(), ec);
    if (ec) throw HistoryError(file.parent_path().string() + ": cannot create: " + ec.message());
  }
  if (!write && !std::filesystem::exists(file)) {
    throw HistoryError(file.string() + ": no such history database");
  }
  const int flags = (write ? SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE : SQLITE_OPEN_READONLY) |
                    SQLITE_OPEN_NOMUTEX;
  if (sqlite3_open_v2(file.c_str(), &db_, flags, nullptr) != SQLITE_OK) {
    const std::string what = db_ != nullptr ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    db_ = nullptr;
    throw HistoryError(file.string() + ": cannot open: " + what);
  }
  try {
    sqlite3_busy_timeout(db_, busy_timeout_ms);
    if (write && sqlite3_db_readonly(db_, "main") == 1) {
      throw HistoryError(file.string() + ": read-only: the run cannot record into it");
    }
    // Read first: a newer file is refused before any statement could write to it.
    const int version = schema_version();
    if (version > kHistorySchemaVersion) {
      throw HistoryError(file.string() + ": history schema version " + std::to_string(version) +
                         " is newer than this projtour knows (" +
                         std::to_string(kHistorySchemaVersion) +
                         "); left unchanged: use a newer projtour");
    }
    {
      Statement check(db_, "PRAGMA quick_check", file_);
      while (check.step()) {
        if (check.text(0) != "ok") {
          throw HistoryError(file.string() + ": corrupt (quick_check: " + check.text(0) + ")");
        }
      }
    }
    if (write) {
      // WAL: readers never block the writer, and a writer killed mid-transaction leaves the
      // main file as the last commit had it. synchronous=NORMAL in WAL is crash-consistent
      // (a power cut may lose the last commits, never the file).
      exec("PRAGMA journal_mode=WAL");
      exec("PRAGMA synchronous=NORMAL");
      exec("PRAGMA foreign_keys=ON");
      migrate();
    } else if (version < kHistorySchemaVersion) {
      throw HistoryError(file.string() + ": history schema version " + std::to_string(version) +
                         " is older than this projtour's; a run records into it to migrate it");
    }
  } catch (...) {
    sqlite3_close(db_);
    db_ = nullptr;
    throw;
  }
}

HistoryDb::~HistoryDb() {
  sqlite3_close(db_);
}

void HistoryDb::exec(const std::string& sql) const {
  char* message = nullptr;
  const int rc = sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &message);
  if (rc != SQLITE_OK) {
    std::string what = message != nullptr ? message : sqlite3_errstr(rc);
    sqlite3_free(message);
    if ((rc & 0xff) == SQLITE_BUSY) what = "locked by another writer past the busy timeout";
    if ((rc & 0xff) == SQLITE_NOTADB || (rc & 0xff) == SQLITE_CORRUPT) what = "corrupt: " + what;
    throw HistoryError(file_.string() + ": " + what);
  }
}

int HistoryDb::schema_version() const {
  sqlite3_stmt* stmt = nullptr;
  int rc = sqlite3_prepare_v2(db_, "PRAGMA user_version", -1, &stmt, nullptr);
  if (rc == SQLITE_OK) rc = sqlite3_step(stmt);
  const int version = rc == SQLITE_ROW ? sqlite3_column_int(stmt, 0) : -1;
  sqlite3_finalize(stmt);
  if (rc != SQLITE_ROW) {
    std::string what = sqlite3_errmsg(db_);
    if ((rc & 0xff) == SQLITE_NOTADB || (rc & 0xff) == SQLITE_CORRUPT) what = "corrupt: " + what;
    if ((rc & 0xff) == SQLITE_BUSY) what = "locked past the busy timeout";
    throw HistoryError(file_.string() + ": " + what);
  }
  return version;
}

void HistoryDb::migrate() {
  if (schema_version() == kHistorySchemaVersion) return;
  // IMMEDIATE: two runs opening one new file at once migrate it once; the second waits, then
  // reads the version the first wrote.
  exec("BEGIN IMMEDIATE");
  try {
    for (int v = schema_version(); v < kHistorySchemaVersion; ++v) {
      exec(kMigrations[v]);
      exec("PRAGMA user_version=" + std::to_string(v + 1));
    }
    exec("COMMIT");
  } catch (...) {
    sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
    throw;
  }
}

std::optional<HistoryRun> HistoryDb::find_run_by_dir(const std::string& run_dir) const {
  Statement q(db_, std::string(kRunColumns) + "WHERE run_dir = ?1 ORDER BY started_at DESC LIMIT 1",
              file_);
  q.bind(1, run_dir);
  if (!q.step()) return std::nullopt;
  return run_from(q);
}

std::vector<HistoryRun> HistoryDb::runs() const {
  Statement q(db_, std::string(kRunColumns) + "ORDER BY started_at", file_);
  std::vector<HistoryRun> out;
  while (q.step()) {
    out.push_back(run_from(q));
  }
  return out;
}

void HistoryDb::upsert_run(const HistoryRun& run) {
  Statement q(db_,
              "INSERT INTO runs (id, mission, robot, run_dir, started_at, ended_at, dry_run, seed, "
              "outcome) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9) "
              "ON CONFLICT(id) DO UPDATE SET ended_at = excluded.ended_at, "
              "outcome = excluded.outcome",
              file_);
  q.bind(1, run.id);
  q.bind(2, run.mission);
  q.bind(3, run.robot);
  q.bind(4, run.run_dir);
  q.bind(5, run.started_at_s);
  q.bind(6, run.ended_at_s);
  q.bind(7, static_cast<std::int64_t>(run.dry_run ? 1 : 0));
  // SQLite's integers are signed: a seed above 2^63 is kept by its bit pattern.
  q.bind(8, static_cast<std::int64_t>(run.seed));
  q.bind(9, run.outcome);
  q.step();
}

void HistoryDb::record_visit(const HistoryVisit& v) {
  exec("BEGIN IMMEDIATE");
  try {
    {
      Statement q(db_,
                  "INSERT OR REPLACE INTO visits (run_id, round, target, content, started_at, "
                  "ended_at, shown_s, blanked_s, observed_error_mm, true_error_mm, outcome, "
                  "reason) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12)",
                  file_);
      q.bind(1, v.run_id);
      q.bind(2, static_cast<std::int64_t>(v.round));
      q.bind(3, v.target);
      q.bind(4, v.content);
      q.bind(5, v.started_at_s);
      q.bind(6, v.ended_at_s);
      q.bind(7, v.shown_s);
      q.bind(8, v.blanked_s);
      q.bind(9, v.observed_error_mm);
      q.bind(10, v.true_error_mm);
      q.bind(11, v.outcome);
      q.bind(12, v.reason);
      q.step();
    }
    {
      Statement d(db_, "DELETE FROM proofs WHERE run_id = ?1 AND round = ?2 AND target = ?3",
                  file_);
      d.bind(1, v.run_id);
      d.bind(2, static_cast<std::int64_t>(v.round));
      d.bind(3, v.target);
      d.step();
    }
    if (!v.proof_path.empty()) {
      Statement p(db_,
                  "INSERT INTO proofs (run_id, round, target, path, sha256) "
                  "VALUES (?1, ?2, ?3, ?4, ?5)",
                  file_);
      p.bind(1, v.run_id);
      p.bind(2, static_cast<std::int64_t>(v.round));
      p.bind(3, v.target);
      p.bind(4, v.proof_path);
      p.bind(5, v.proof_sha256);
      p.step();
    }
    {
      Statement r(db_, "UPDATE runs SET ended_at = max(coalesce(ended_at, 0), ?2) WHERE id = ?1",
                  file_);
      r.bind(1, v.run_id);
      r.bind(2, v.ended_at_s);
      r.step();
    }
    exec("COMMIT");
  } catch (...) {
    sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
    throw;
  }
}

std::vector<HistoryVisit> HistoryDb::visits() const {
  Statement q(db_,
              "SELECT v.run_id, v.round, v.target, v.content, v.started_at, v.ended_at, v.shown_s, "
              "v.blanked_s, v.observed_error_mm, v.true_error_mm, v.outcome, v.reason, "
              "coalesce(p.path, ''), coalesce(p.sha256, '') FROM visits v LEFT JOIN proofs p "
              "USING (run_id, round, target) ORDER BY v.started_at, v.target",
              file_);
  std::vector<HistoryVisit> out;
  while (q.step()) {
    HistoryVisit v;
    v.run_id = q.text(0);
    v.round = static_cast<int>(q.integer(1));
    v.target = q.text(2);
    v.content = q.text(3);
    v.started_at_s = q.real(4);
    v.ended_at_s = q.real(5);
    v.shown_s = q.real(6);
    v.blanked_s = q.real(7);
    v.observed_error_mm = q.maybe(8);
    v.true_error_mm = q.maybe(9);
    v.outcome = q.text(10);
    v.reason = q.text(11);
    v.proof_path = q.text(12);
    v.proof_sha256 = q.text(13);
    out.push_back(std::move(v));
  }
  return out;
}

std::string sha256_hex(const std::vector<unsigned char>& bytes) {
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int n = 0;
  if (EVP_Digest(bytes.data(), bytes.size(), digest, &n, EVP_sha256(), nullptr) != 1) {
    throw std::runtime_error("SHA-256 failed");
  }
  return hex(digest, n);
}

StoredProof store_proof(const std::filesystem::path& db, const std::vector<unsigned char>& jpeg) {
  StoredProof proof;
  proof.sha256 = sha256_hex(jpeg);
  const std::filesystem::path dir = proofs_dir_of(db);
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw HistoryError(dir.string() + ": cannot create: " + ec.message());
  const std::string name = proof.sha256.substr(0, 32) + ".jpg";
  const std::filesystem::path file = dir / name;
  proof.relative_path = dir.filename().string() + "/" + name;
  if (std::filesystem::exists(file) && std::filesystem::file_size(file, ec) == jpeg.size()) {
    return proof;
  }
  // Written under a temporary name and renamed: a proof file is whole or absent, so a kill
  // while it is written never leaves a row pointing at half an image.
  const std::filesystem::path part = dir / (name + ".part" + std::to_string(::getpid()));
  {
    std::ofstream f(part, std::ios::binary | std::ios::trunc);
    f.write(reinterpret_cast<const char*>(jpeg.data()), static_cast<std::streamsize>(jpeg.size()));
    f.close();
    if (!f) {
      std::filesystem::remove(part, ec);
      throw HistoryError(file.string() + ": cannot write the proof image");
    }
  }
  std::filesystem::rename(part, file, ec);
  if (ec) throw HistoryError(file.string() + ": cannot write the proof image: " + ec.message());
  return proof;
}

}  // namespace projtour
