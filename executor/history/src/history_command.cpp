// `projtour history`: the history database summed up by content, target, day or run, as a table,
// CSV, JSON or a page with the proof images (history.hpp).
#include <sqlite3.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <iomanip>
#include <map>
#include <ostream>
#include <set>
#include <sstream>

#include "projtour/formats/html_escape.hpp"
#include "projtour/formats/json_io.hpp"
#include "projtour/history/history.hpp"

namespace projtour {

namespace {

std::string fixed(double v, int digits) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f", digits, v);
  return buffer;
}

std::string fixed(const std::optional<double>& v, int digits) {
  return v ? fixed(*v, digits) : "-";
}

std::optional<double> median(std::vector<double> values) {
  if (values.empty()) return std::nullopt;
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 == 1 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

std::optional<double> worst(const std::vector<double>& values) {
  if (values.empty()) return std::nullopt;
  return *std::max_element(values.begin(), values.end());
}

// The WHERE clause and its bindings, shared by the summary and the page's showings.
struct Filter {
  std::string where;
  std::vector<std::pair<int, std::string>> texts;
  std::vector<std::pair<int, double>> reals;
};

Filter filter_of(const HistoryQuery& q) {
  Filter f;
  f.where = " WHERE 1";
  if (!q.include_dry_runs) f.where += " AND r.dry_run = 0";
  if (q.from_s) {
    f.where += " AND v.started_at >= ?1";
    f.reals.emplace_back(1, *q.from_s);
  }
  if (q.to_s) {
    f.where += " AND v.started_at < ?2";
    f.reals.emplace_back(2, *q.to_s);
  }
  if (q.content) {
    f.where += " AND v.content = ?3";
    f.texts.emplace_back(3, *q.content);
  }
  if (q.target) {
    f.where += " AND v.target = ?4";
    f.texts.emplace_back(4, *q.target);
  }
  return f;
}

sqlite3_stmt* prepare(const HistoryDb& db, const std::string& sql, const Filter& f) {
  sqlite3_stmt* stmt = nullptr;
  if (sqlite3_prepare_v2(db.handle(), sql.c_str(), -1, &stmt, nullptr) != SQLITE_OK) {
    throw HistoryError(db.file().string() + ": " + sqlite3_errmsg(db.handle()));
  }
  for (const auto& [i, s] : f.texts) {
    sqlite3_bind_text(stmt, i, s.c_str(), static_cast<int>(s.size()), SQLITE_TRANSIENT);
  }
  for (const auto& [i, v] : f.reals) sqlite3_bind_double(stmt, i, v);
  return stmt;
}

// Steps a statement, throwing on an error (a busy or corrupt file) rather than ending early.
bool next_row(const HistoryDb& db, sqlite3_stmt* stmt) {
  const int rc = sqlite3_step(stmt);
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  const std::string what = sqlite3_errmsg(db.handle());
  sqlite3_finalize(stmt);
  throw HistoryError(db.file().string() + ": " + what);
}

std::string column_text(sqlite3_stmt* stmt, int i) {
  const unsigned char* t = sqlite3_column_text(stmt, i);
  return t == nullptr ? std::string() : reinterpret_cast<const char*>(t);
}

std::string key_expression(const std::string& by) {
  if (by == "target") return "v.target";
  if (by == "day") return "strftime('%Y-%m-%d', v.started_at, 'unixepoch')";
  if (by == "run") return "v.run_id";
  return "v.content";
}

std::string utc_text(double unix_s) {
  const std::time_t t = static_cast<std::time_t>(std::floor(unix_s));
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buffer[32];
  std::strftime(buffer, sizeof buffer, "%Y-%m-%d %H:%M:%S", &tm);
  return buffer;
}

Json optional_json(const std::optional<double>& v) {
  return v ? Json(*v) : Json(nullptr);
}

}  // namespace

std::optional<double> parse_history_time(const std::string& text, bool* date_only) {
  int y = 0, mo = 0, d = 0, h = 0, mi = 0, s = 0;
  char rest[8] = {0};
  int used = 0;
  bool only_date = false;
  if (text.size() == 10 && std::sscanf(text.c_str(), "%4d-%2d-%2d%n", &y, &mo, &d, &used) == 3 &&
      used == 10) {
    only_date = true;
  } else if (std::sscanf(text.c_str(), "%4d-%2d-%2dT%2d:%2d%n", &y, &mo, &d, &h, &mi, &used) == 5 &&
             used == 16) {
    std::string tail = text.substr(16);
    if (tail.size() >= 3 && tail[0] == ':') {
      if (std::sscanf(tail.c_str(), ":%2d%n", &s, &used) != 1 || used != 3) return std::nullopt;
      tail = tail.substr(3);
    }
    if (!tail.empty() && tail != "Z") return std::nullopt;
  } else {
    return std::nullopt;
  }
  (void)rest;
  if (text[4] != '-' || text[7] != '-') return std::nullopt;
  if (mo < 1 || mo > 12 || d < 1 || d > 31 || h > 23 || mi > 59 || s > 59) return std::nullopt;
  std::tm tm{};
  tm.tm_year = y - 1900;
  tm.tm_mon = mo - 1;
  tm.tm_mday = d;
  tm.tm_hour = h;
  tm.tm_min = mi;
  tm.tm_sec = s;
  const std::time_t t = timegm(&tm);
  // timegm normalizes 2026-02-30 to March 2nd: a date that does not round-trip does not exist.
  std::tm back{};
  gmtime_r(&t, &back);
  if (back.tm_mday != d || back.tm_mon != mo - 1) return std::nullopt;
  if (date_only != nullptr) *date_only = only_date;
  return static_cast<double>(t);
}

std::vector<HistoryRow> summarize_history(const HistoryDb& db, const HistoryQuery& query) {
  const Filter f = filter_of(query);
  const std::string sql = "SELECT " + key_expression(query.by) +
                          ", r.dry_run, v.outcome, v.shown_s, v.blanked_s, v.observed_error_mm, "
                          "v.true_error_mm FROM visits v JOIN runs r ON r.id = v.run_id" +
                          f.where;
  sqlite3_stmt* stmt = prepare(db, sql, f);
  struct Acc {
    HistoryRow row;
    std::vector<double> observed, truth;
  };
  std::map<std::pair<std::string, bool>, Acc> groups;
  while (next_row(db, stmt)) {
    const std::string key = column_text(stmt, 0);
    const bool dry = sqlite3_column_int(stmt, 1) != 0;
    Acc& a = groups[{key, dry}];
    a.row.key = key;
    a.row.dry_run = dry;
    ++a.row.visits;
    if (column_text(stmt, 2) == "projected") ++a.row.showings;
    a.row.shown_s += sqlite3_column_double(stmt, 3);
    a.row.blanked_s += sqlite3_column_double(stmt, 4);
    if (sqlite3_column_type(stmt, 5) != SQLITE_NULL) {
      a.observed.push_back(sqlite3_column_double(stmt, 5));
    }
    if (sqlite3_column_type(stmt, 6) != SQLITE_NULL) {
      a.truth.push_back(sqlite3_column_double(stmt, 6));
    }
  }
  sqlite3_finalize(stmt);
  std::vector<HistoryRow> rows;
  for (auto& [key, a] : groups) {
    a.row.median_observed_mm = median(a.observed);
    a.row.worst_observed_mm = worst(a.observed);
    a.row.median_true_mm = median(a.truth);
    a.row.worst_true_mm = worst(a.truth);
    rows.push_back(a.row);
  }
  return rows;
}

std::vector<HistoryShowing> history_showings(const HistoryDb& db, const HistoryQuery& query) {
  const Filter f = filter_of(query);
  const std::string sql =
      "SELECT strftime('%Y-%m-%d', v.started_at, 'unixepoch'), v.content, v.target, v.run_id, "
      "v.round, v.started_at, v.shown_s, v.observed_error_mm, coalesce(p.path, ''), "
      "coalesce(p.sha256, '') FROM visits v JOIN runs r ON r.id = v.run_id LEFT JOIN proofs p "
      "ON p.run_id = v.run_id AND p.round = v.round AND p.target = v.target" +
      f.where + " AND v.outcome = 'projected' ORDER BY v.started_at, v.target";
  sqlite3_stmt* stmt = prepare(db, sql, f);
  std::vector<HistoryShowing> out;
  while (next_row(db, stmt)) {
    HistoryShowing s;
    s.day = column_text(stmt, 0);
    s.content = column_text(stmt, 1);
    s.target = column_text(stmt, 2);
    s.run_id = column_text(stmt, 3);
    s.round = sqlite3_column_int(stmt, 4);
    s.started_at_s = sqlite3_column_double(stmt, 5);
    s.shown_s = sqlite3_column_double(stmt, 6);
    if (sqlite3_column_type(stmt, 7) != SQLITE_NULL) {
      s.observed_error_mm = sqlite3_column_double(stmt, 7);
    }
    s.proof_path = column_text(stmt, 8);
    s.proof_sha256 = column_text(stmt, 9);
    out.push_back(std::move(s));
  }
  sqlite3_finalize(stmt);
  return out;
}

void print_history_table(const std::vector<HistoryRow>& rows, const HistoryQuery& query,
                         std::ostream& out) {
  std::size_t width = query.by.size();
  for (const auto& r : rows) width = std::max(width, r.key.size() + (r.dry_run ? 6 : 0));
  out << std::left << std::setw(static_cast<int>(width)) << query.by << std::right << std::setw(10)
      << "shown_s" << std::setw(10) << "showings" << std::setw(8) << "visits" << std::setw(11)
      << "blanked_s" << std::setw(14) << "median_obs_mm" << std::setw(13) << "worst_obs_mm";
  if (query.include_dry_runs)
    out << std::setw(15) << "median_true_mm" << std::setw(14) << "worst_true_mm";
  out << "\n";
  for (const auto& r : rows) {
    out << std::left << std::setw(static_cast<int>(width)) << (r.dry_run ? r.key + " (dry)" : r.key)
        << std::right << std::setw(10) << fixed(r.shown_s, 1) << std::setw(10) << r.showings
        << std::setw(8) << r.visits << std::setw(11) << fixed(r.blanked_s, 1) << std::setw(14)
        << fixed(r.median_observed_mm, 2) << std::setw(13) << fixed(r.worst_observed_mm, 2);
    if (query.include_dry_runs) {
      out << std::setw(15) << fixed(r.median_true_mm, 2) << std::setw(14)
          << fixed(r.worst_true_mm, 2);
    }
    out << "\n";
  }
  if (rows.empty()) out << "(no visits in the range)\n";
}

void print_history_csv(const std::vector<HistoryRow>& rows, std::ostream& out) {
  out << "key,dry_run,shown_s,showings,visits,blanked_s,median_observed_mm,worst_observed_mm,"
         "median_true_mm,worst_true_mm\n";
  auto cell = [](const std::optional<double>& v) { return v ? fixed(*v, 3) : std::string(); };
  for (const auto& r : rows) {
    // RFC 4180: a field with a comma, quote or line break is quoted, its quotes doubled.
    std::string key = r.key;
    if (key.find_first_of(",\"\n\r") != std::string::npos) {
      std::string quoted = "\"";
      for (const char c : key) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
      key = quoted + "\"";
    }
    out << key << "," << (r.dry_run ? 1 : 0) << "," << fixed(r.shown_s, 3) << "," << r.showings
        << "," << r.visits << "," << fixed(r.blanked_s, 3) << "," << cell(r.median_observed_mm)
        << "," << cell(r.worst_observed_mm) << "," << cell(r.median_true_mm) << ","
        << cell(r.worst_true_mm) << "\n";
  }
}

void print_history_json(const std::vector<HistoryRow>& rows, const HistoryQuery& query,
                        std::ostream& out) {
  Json j = Json::object();
  j["by"] = query.by;
  j["from"] = query.from_s ? Json(utc_text(*query.from_s)) : Json(nullptr);
  j["to"] = query.to_s ? Json(utc_text(*query.to_s)) : Json(nullptr);
  j["include_dry_runs"] = query.include_dry_runs;
  j["rows"] = Json::array();
  for (const auto& r : rows) {
    Json row = Json::object();
    row["key"] = r.key;
    row["dry_run"] = r.dry_run;
    row["shown_s"] = r.shown_s;
    row["showings"] = r.showings;
    row["visits"] = r.visits;
    row["blanked_s"] = r.blanked_s;
    row["median_observed_mm"] = optional_json(r.median_observed_mm);
    row["worst_observed_mm"] = optional_json(r.worst_observed_mm);
    row["median_true_mm"] = optional_json(r.median_true_mm);
    row["worst_true_mm"] = optional_json(r.worst_true_mm);
    j["rows"].push_back(row);
  }
  out << dump_json(j, 2) << "\n";
}

void write_history_page(const HistoryDb& db, const HistoryQuery& query,
                        const std::filesystem::path& html_file) {
  HistoryQuery by_content = query;
  by_content.by = "content";
  const std::vector<HistoryRow> totals = summarize_history(db, by_content);
  const std::vector<HistoryShowing> showings = history_showings(db, query);
  // The images are referenced from the page's own directory, so the page can be opened from
  // disk (file://) wherever it is written.
  std::error_code ec;
  const std::filesystem::path page_dir =
      std::filesystem::absolute(html_file.parent_path().empty() ? "." : html_file.parent_path());
  const std::filesystem::path db_dir = std::filesystem::absolute(db.file()).parent_path();
  std::ostringstream h;
  h << "<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>projtour "
       "proof of play</title>\n<style>body{font-family:sans-serif;margin:1.5em}"
       "table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:3px 8px;"
       "text-align:right}td:first-child,th:first-child{text-align:left}"
       ".cal td{text-align:center;min-width:3em}.proofs{display:flex;flex-wrap:wrap;gap:8px}"
       "figure{margin:0;font-size:12px;width:320px}img{width:320px}</style></head><body>\n";
  h << "<h1>Proof of play</h1>\n<p>"
    << (query.from_s ? "from " + utc_text(*query.from_s) + " UTC " : std::string())
    << (query.to_s ? "to " + utc_text(*query.to_s) + " UTC " : std::string())
    << (query.include_dry_runs ? "(dry runs included)" : "(real runs only)") << "</p>\n";
  h << "<h2>Totals by content</h2>\n<table id=\"totals\"><tr><th>content</th><th>seconds "
       "shown</th><th>showings</th><th>blanked s</th><th>median observed mm</th><th>worst "
       "observed mm</th></tr>\n";
  for (const auto& r : totals) {
    h << "<tr data-content=\"" << html_escape(r.key) << "\"><td>" << html_escape(r.key)
      << (r.dry_run ? " (dry)" : "") << "</td><td class=\"shown\">" << fixed(r.shown_s, 1)
      << "</td><td class=\"showings\">" << r.showings << "</td><td>" << fixed(r.blanked_s, 1)
      << "</td><td>" << fixed(r.median_observed_mm, 2) << "</td><td>"
      << fixed(r.worst_observed_mm, 2) << "</td></tr>\n";
  }
  h << "</table>\n<h2>Calendar of showings</h2>\n<table class=\"cal\" id=\"calendar\"><tr><th>"
       "day</th>";
  std::set<std::string> contents;
  std::map<std::string, std::map<std::string, int>> per_day;
  for (const auto& s : showings) {
    contents.insert(s.content);
    ++per_day[s.day][s.content];
  }
  for (const auto& c : contents) h << "<th>" << html_escape(c) << "</th>";
  h << "</tr>\n";
  for (const auto& [day, counts] : per_day) {
    h << "<tr><td>" << day << "</td>";
    for (const auto& c : contents) {
      const auto it = counts.find(c);
      h << "<td>" << (it == counts.end() ? 0 : it->second) << "</td>";
    }
    h << "</tr>\n";
  }
  h << "</table>\n<h2>Proof images</h2>\n<div class=\"proofs\">\n";
  for (const auto& s : showings) {
    if (s.proof_path.empty()) continue;
    const std::filesystem::path image = db_dir / s.proof_path;
    const std::string src = std::filesystem::relative(image, page_dir, ec).generic_string();
    h << "<figure><img class=\"proof\" src=\"" << html_escape(ec ? image.string() : src)
      << "\" alt=\"" << html_escape(s.content + " on " + s.target) << "\" data-sha256=\""
      << s.proof_sha256
      << "\" onload=\"this.dataset.loaded=1\" onerror=\"this.dataset.loaded=0\"><figcaption>"
      << html_escape(s.content) << " on " << html_escape(s.target) << ", "
      << utc_text(s.started_at_s) << " UTC"
      << (s.round > 0 ? ", round " + std::to_string(s.round) : std::string()) << ", "
      << fixed(s.shown_s, 1) << " s, observed " << fixed(s.observed_error_mm, 2)
      << " mm</figcaption></figure>\n";
  }
  h << "</div>\n</body></html>\n";
  std::ofstream f(html_file, std::ios::trunc);
  f << h.str();
  f.close();
  if (!f) throw std::runtime_error(html_file.string() + ": cannot write the page");
}

int history_command(int argc, char** argv, std::ostream& out, std::ostream& err) {
  CLI::App app("projtour history", "projtour history");
  app.set_help_flag();
  app.allow_extras();
  std::string file, from, to, html;
  HistoryQuery query;
  bool csv = false, json = false;
  std::string content, target;
  app.add_option("--history", file)->type_name("FILE");
  app.add_option("--from", from)->type_name("DATE[THH:MM[:SS]]");
  app.add_option("--to", to)->type_name("DATE[THH:MM[:SS]]");
  app.add_option("--content", content)->type_name("NAME");
  app.add_option("--target", target)->type_name("ID");
  app.add_option("--by", query.by)->type_name("content|target|day|run");
  app.add_flag("--csv", csv);
  app.add_flag("--json", json);
  app.add_option("--html", html)->type_name("FILE");
  app.add_flag("--include-dry-runs", query.include_dry_runs);
  for (CLI::Option* option : app.get_options()) {
    option->multi_option_policy(CLI::MultiOptionPolicy::Throw);
  }
  auto usage = [&](const std::string& message) {
    err << "projtour history: " << message
        << "\nusage: projtour history [--history FILE] [--from T] [--to T] [--content NAME] "
           "[--target ID] [--by content|target|day|run] [--csv | --json | --html FILE] "
           "[--include-dry-runs]\n  T: YYYY-MM-DD or YYYY-MM-DDTHH:MM[:SS][Z], UTC\n";
    return 2;
  };
  try {
    app.parse(argc - 1, argv + 1);
  } catch (const CLI::ParseError& e) {
    return usage(e.what());
  }
  for (const std::string& extra : app.remaining()) {
    return usage((extra.rfind("-", 0) == 0 ? "unknown option " : "unexpected argument ") + extra);
  }
  if (!from.empty() || app.count("--from") > 0) {
    query.from_s = parse_history_time(from);
    if (!query.from_s) {
      return usage("--from: expected YYYY-MM-DD or YYYY-MM-DDTHH:MM[:SS], got \"" + from + "\"");
    }
  }
  if (!to.empty() || app.count("--to") > 0) {
    bool date_only = false;
    query.to_s = parse_history_time(to, &date_only);
    if (!query.to_s) {
      return usage("--to: expected YYYY-MM-DD or YYYY-MM-DDTHH:MM[:SS], got \"" + to + "\"");
    }
    if (date_only) *query.to_s += 86400.0;  // the whole of that day
  }
  if (query.from_s && query.to_s && *query.to_s <= *query.from_s) {
    return usage("--to: must come after --from");
  }
  if (query.by != "content" && query.by != "target" && query.by != "day" && query.by != "run") {
    return usage("--by: expected content, target, day or run, got \"" + query.by + "\"");
  }
  if (int(csv) + int(json) + int(!html.empty()) > 1) {
    return usage("--csv, --json and --html: one at a time");
  }
  if (!content.empty()) query.content = content;
  if (!target.empty()) query.target = target;
  const std::filesystem::path db_file =
      file.empty() ? default_history_path() : std::filesystem::path(file);
  if (db_file.empty()) return usage("--history: no default (neither XDG_DATA_HOME nor HOME set)");
  try {
    HistoryDb db(db_file, HistoryAccess::read_only);
    if (!html.empty()) {
      write_history_page(db, query, html);
      out << "projtour history: wrote " << html << "\n";
      return 0;
    }
    const auto rows = summarize_history(db, query);
    if (csv) {
      print_history_csv(rows, out);
    } else if (json) {
      print_history_json(rows, query, out);
    } else {
      print_history_table(rows, query, out);
    }
  } catch (const std::exception& e) {
    err << "projtour history: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

}  // namespace projtour
