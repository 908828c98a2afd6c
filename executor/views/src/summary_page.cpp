#include "projtour/views/summary_page.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "assets.hpp"
#include "projtour/formats/html_escape.hpp"
#include "projtour/record/record_fields.hpp"
#include "projtour/run/atomic_file.hpp"
#include "projtour/views/tour_picture.hpp"

namespace projtour {

namespace {

// Percent-encodes one path segment (a target id may hold any character a YAML string can).
std::string url_segment(const std::string& s) {
  std::string out;
  for (unsigned char c : s) {
    if (std::isalnum(c) || c == '-' || c == '_' || c == '.' || c == '~') {
      out += static_cast<char>(c);
    } else {
      char buf[4];
      std::snprintf(buf, sizeof buf, "%%%02X", c);
      out += buf;
    }
  }
  return out;
}

// An HTML id/anchor from a target id and its round (0 without a schedule: one visit each).
std::string anchor(const std::string& id, long long round = 0) {
  std::string out = "target-";
  for (unsigned char c : id) out += std::isalnum(c) ? static_cast<char>(c) : '_';
  if (round > 0) out += "-round-" + std::to_string(round);
  return out;
}

long long round_of(const Json& t) {
  const Json* v = t.is_object() && t.contains("round") ? &t.at("round") : nullptr;
  return v != nullptr && v->is_number_integer() ? v->get<long long>() : 0;
}

const Json* at_path(const Json& j, std::initializer_list<const char*> keys) {
  const Json* v = &j;
  for (const char* k : keys) {
    if (!v->is_object()) return nullptr;
    const auto it = v->find(k);
    if (it == v->end()) return nullptr;
    v = &*it;
  }
  return v;
}

std::optional<double> number(const Json& j, std::initializer_list<const char*> keys) {
  const Json* v = at_path(j, keys);
  if (v == nullptr || !v->is_number()) return std::nullopt;
  return v->get<double>();
}

std::string text(const Json& j, std::initializer_list<const char*> keys) {
  const Json* v = at_path(j, keys);
  if (v == nullptr || v->is_null()) return "";
  if (v->is_string()) return v->get<std::string>();
  if (v->is_boolean()) return v->get<bool>() ? "yes" : "no";
  return dump_json(*v);
}

std::string fixed(double v, int precision) {
  std::ostringstream out;
  out << std::fixed << std::setprecision(precision) << v;
  return out.str();
}

std::string fixed_or_dash(std::optional<double> v, int precision) {
  return v ? fixed(*v, precision) : "-";
}

std::string duration(double s) {
  if (s < 120.0) return fixed(s, 1) + " s";
  const long total = static_cast<long>(std::lround(s));
  std::ostringstream out;
  out << total / 60 << " min " << std::setw(2) << std::setfill('0') << total % 60 << " s ("
      << fixed(s, 1) << " s)";
  return out.str();
}

std::string colour_css(const RgbColour& c) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "#%02x%02x%02x", c.r, c.g, c.b);
  return buf;
}

std::string badge(const std::string& outcome) {
  RgbColour c = outcome_colour(outcome);
  if (outcome == "completed") c = outcome_colour("projected");
  if (outcome == "completed_with_skips" || outcome == "interrupted") c = outcome_colour("skipped");
  if (outcome == "aborted") c = outcome_colour("failed");
  return "<span class=\"badge\" style=\"background:" + colour_css(c) + "\">" +
         html_escape(outcome.empty() ? "unknown" : outcome) + "</span>";
}

std::string img_tag(const std::string& src, const std::string& alt) {
  // The handlers let a headless browser (the test) see whether each picture decoded.
  return "<img src=\"" + src + "\" alt=\"" + html_escape(alt) +
         "\" onload=\"this.dataset.loaded=this.naturalWidth&gt;0?'1':'0'\" "
         "onerror=\"this.dataset.loaded='0'\">";
}

// Joins the parts that are present with a middle dot.
std::string joined(const std::vector<std::string>& parts) {
  std::string out;
  for (const auto& p : parts) {
    if (p.empty()) continue;
    if (!out.empty()) out += " &middot; ";
    out += p;
  }
  return out;
}

std::string with_unit(std::optional<double> v, int precision, const std::string& unit) {
  return v ? fixed(*v, precision) + unit : "";
}

// Every leaf of `j` as "a.b" -> value text, for fields this page has no dedicated row for.
void flatten(const Json& j, const std::string& prefix,
             std::vector<std::pair<std::string, std::string>>& out) {
  if (j.is_object()) {
    for (auto it = j.begin(); it != j.end(); ++it) {
      flatten(it.value(), prefix.empty() ? it.key() : prefix + "." + it.key(), out);
    }
  } else {
    out.emplace_back(prefix, j.is_string() ? j.get<std::string>() : dump_json(j));
  }
}

using Rows = std::vector<std::pair<std::string, std::string>>;  // label, HTML

// One figure as its PageFormat shows it ("" when `v` is absent or not of its kind).
std::string shown(const Json* v, const PageFormat& page) {
  if (v == nullptr) return "";
  if (page.precision == PageFormat::kAsText) {
    const std::string t = text(*v, {});
    return t.empty() ? "" : page.before + html_escape(t) + page.unit;
  }
  if (!v->is_number()) return "";
  return page.before + fixed(page.scale * v->get<double>(), page.precision) + page.unit;
}

// A nested type's row: its shown fields' parts joined.
template <class T>
std::string parts_of(const Json& value) {
  static const T kShape{};
  std::vector<std::string> parts;
  for_each_field(kShape, [&](const auto& f, const auto&) {
    if (f.page.shown) parts.push_back(shown(at_path(value, {f.key}), f.page));
  });
  return joined(parts);
}

// The rows that join figures of several fields, by the key of the field whose row it is.
bool joined_rows(const Json& t, const std::string& key, const PageFormat& page, Rows& rows) {
  if (key == "outcome") {
    rows.emplace_back(page.label, badge(text(t, {"outcome"})));
  } else if (key == "beam_interruptions") {
    if (auto n = number(t, {"beam_interruptions"}); n && *n > 0) {
      rows.emplace_back(page.label, fixed(*n, 0) + " interruptions, blanked " +
                                        fixed(number(t, {"blanked_s"}).value_or(0.0), 1) + " s");
    }
  } else if (key == "projection_error_mm") {
    // A row per BeforeAfter field, each with the mm and px figures.
    static const BeforeAfter kShape{};
    for_each_field(kShape, [&](const auto& f, const auto&) {
      const auto mm = number(t, {"projection_error_mm", f.key});
      const auto px = number(t, {"projection_error_px", f.key});
      if (mm || px) {
        rows.emplace_back(std::string(page.label) + " " + f.page.label + " alignment",
                          joined({with_unit(mm, 1, " mm"), with_unit(px, 1, " px")}));
      }
    });
  } else if (key == "observed_error_mm") {
    if (auto observed = number(t, {"observed_error_mm"})) {
      rows.emplace_back(page.label,
                        joined({with_unit(observed, page.precision, page.unit),
                                with_unit(number(t, {"projection_error_mm", "after_align"}), 1,
                                          " mm true (referee)")}));
    }
  } else {
    return false;
  }
  return true;
}

void target_figures(std::ostringstream& h, const Json& t) {
  Rows rows;
  std::set<std::string> known;
  static const TargetRecord kShape{};
  for_each_field(kShape, [&](const auto& f, const auto& owner) {
    known.insert(f.key);
    if (f.page.label == nullptr || joined_rows(t, f.key, f.page, rows)) return;
    const Json* v = at_path(t, {f.key});
    using V = field_value_t<std::decay_t<decltype(owner.*f.member)>>;
    if constexpr (Fields<V>::kDefined) {
      if (v != nullptr) rows.emplace_back(f.page.label, parts_of<V>(*v));
    } else if (const std::string value = shown(v, f.page); !value.empty()) {
      rows.emplace_back(f.page.label, value);
    }
  });
  // Fields of a report this page does not know, every leaf as "a.b".
  Rows other;
  if (t.is_object()) {
    for (auto it = t.begin(); it != t.end(); ++it) {
      if (known.count(it.key()) == 0) flatten(it.value(), it.key(), other);
    }
  }
  for (const auto& [k, v] : other) rows.emplace_back(k, html_escape(v));

  h << "<table class=\"figures\">\n";
  for (const auto& [label, value] : rows) {
    h << "<tr><th>" << html_escape(label) << "</th><td>" << (value.empty() ? "-" : value)
      << "</td></tr>\n";
  }
  h << "</table>\n";
}

void target_pictures(std::ostringstream& h, const std::string& id,
                     const std::filesystem::path& run_dir) {
  static const std::pair<const char*, const char*> kPictures[] = {
      {"alignment.png", "alignment: the model on the captured frame"},
      {"projector.png", "projector frame (warped content)"},
      {"camera_view.png",
       "colour camera: the Model Points expected (green) and the dots observed (red)"},
      {"before.png", "where the content lands without alignment"},
      {"after.png", "where the content lands with alignment"}};
  std::ostringstream figs;
  for (const auto& [file, caption] : kPictures) {
    if (!std::filesystem::is_regular_file(run_dir / "targets" / id / file)) continue;
    const std::string src = "targets/" + url_segment(id) + "/" + file;
    figs << "<figure><a href=\"" << src << "\">" << img_tag(src, id + " " + file)
         << "</a><figcaption>" << html_escape(caption) << "</figcaption></figure>\n";
  }
  const std::string body = figs.str();
  if (!body.empty()) h << "<div class=\"pictures\">\n" << body << "</div>\n";
}

// The rows of `round` (every row when 0, a run without a schedule).
void overview_table(std::ostringstream& h, const Json& targets, long long round) {
  h << "<table class=\"overview\">\n<tr><th>target</th><th>outcome</th>";
  for (const OverviewColumn& c : kOverviewColumns) h << "<th>" << c.page_header << "</th>";
  h << "<th>reason</th></tr>\n";
  for (const Json& t : targets) {
    if (round_of(t) != round) continue;
    const std::string id = text(t, {"id"});
    h << "<tr><td><a href=\"#" << anchor(id, round) << "\">" << html_escape(id)
      << (text(t, {"content"}).empty() ? "" : " (" + html_escape(text(t, {"content"})) + ")")
      << "</a></td><td>" << badge(text(t, {"outcome"})) << "</td><td>";
    for (const OverviewColumn& c : kOverviewColumns) {
      const auto v = c.sub_key ? number(t, {c.key, c.sub_key}) : number(t, {c.key});
      h << fixed_or_dash(v, c.precision) << "</td><td>";
    }
    h << html_escape(text(t, {"reason"})) << "</td></tr>\n";
  }
  h << "</table>\n";
}

// Median and worst projection error after alignment over the targets that have one: the tour's
// headline figure.
std::string projection_error_line(const Json& targets) {
  std::vector<double> after;
  for (const Json& t : targets) {
    if (auto v = number(t, {"projection_error_mm", "after_align"})) after.push_back(*v);
  }
  if (after.empty()) return "";
  std::sort(after.begin(), after.end());
  const std::size_t n = after.size();
  const double median = n % 2 == 1 ? after[n / 2] : 0.5 * (after[n / 2 - 1] + after[n / 2]);
  return "median " + fixed(median, 1) + " mm, worst " + fixed(after.back(), 1) + " mm over " +
         std::to_string(n) + (n == 1 ? " target" : " targets");
}

}  // namespace

SummaryInput read_summary_input(const std::filesystem::path& run_dir) {
  const std::filesystem::path file = run_dir / "report.json";
  std::ifstream in(file, std::ios::binary);
  if (!in) throw std::runtime_error(file.string() + ": cannot read the report");
  const std::string content((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return SummaryInput{parse_json(content, file.string())};
}

std::string render_summary_page(const SummaryInput& input, const std::filesystem::path& run_dir) {
  const Json& r = input.report;
  const std::string mission = text(r, {"mission"});
  static const Json kNoTargets = Json::array();
  const Json* targets_json = at_path(r, {"targets"});
  const Json& targets =
      targets_json != nullptr && targets_json->is_array() ? *targets_json : kNoTargets;

  std::ostringstream h;
  h << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
    << "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
    << "<title>projtour: " << html_escape(mission) << "</title>\n<style>\n"
    << assets::summary_css() << "</style>\n</head>\n<body>\n";
  h << "<h1>" << html_escape(mission.empty() ? "projtour run" : mission) << "</h1>\n";

  h << "<table class=\"summary\">\n";
  h << "<tr><th>outcome</th><td>" << badge(text(r, {"outcome"})) << "</td></tr>\n";
  if (const Json* dry = at_path(r, {"dry_run"}); dry != nullptr && dry->is_boolean()) {
    h << "<tr><th>run</th><td>" << (dry->get<bool>() ? "dry run (simulated world)" : "on the robot")
      << "</td></tr>\n";
  }
  if (at_path(r, {"seed"}) != nullptr) {
    h << "<tr><th>seed</th><td>" << html_escape(text(r, {"seed"})) << "</td></tr>\n";
  }
  if (auto s = number(r, {"timing", "mission_s"})) {
    h << "<tr><th>mission time</th><td>" << duration(*s) << "</td></tr>\n";
  }
  if (auto s = number(r, {"timing", "wall_s"})) {
    h << "<tr><th>wall-clock time</th><td>" << duration(*s) << "</td></tr>\n";
  }
  std::size_t projected = 0;
  for (const Json& t : targets) projected += text(t, {"outcome"}) == "projected" ? 1 : 0;
  long long last_round = 0;
  for (const Json& t : targets) last_round = std::max(last_round, round_of(t));
  if (last_round > 0) {
    h << "<tr><th>visits projected</th><td>" << projected << " of " << targets.size() << " in "
      << last_round << (last_round == 1 ? " round" : " rounds") << "</td></tr>\n";
  } else {
    h << "<tr><th>targets projected</th><td>" << projected << " of " << targets.size()
      << "</td></tr>\n";
  }
  if (const std::string line = projection_error_line(targets); !line.empty()) {
    h << "<tr><th>projection error after alignment</th><td>" << line << "</td></tr>\n";
  }
  h << "</table>\n";

  if (std::filesystem::is_regular_file(run_dir / "tour.png")) {
    h << "<h2>Tour</h2>\n<div class=\"tour\"><a href=\"tour.png\">"
      << img_tag("tour.png", "the tour on the map") << "</a></div>\n";
  }
  // A schedule's rounds, in the report's order (round by round); {0} without one.
  std::vector<long long> rounds;
  for (const Json& t : targets) {
    if (rounds.empty() || rounds.back() != round_of(t)) rounds.push_back(round_of(t));
  }
  if (!targets.empty()) h << "<h2>Targets</h2>\n";
  for (long long round : rounds) {
    if (round > 0) {
      std::size_t visits = 0, shown = 0;
      for (const Json& t : targets) {
        if (round_of(t) != round) continue;
        ++visits;
        shown += text(t, {"outcome"}) == "projected" ? 1 : 0;
      }
      h << "<h3 id=\"round-" << round << "\">Round " << round << ": " << shown << " of " << visits
        << " projected</h3>\n";
    }
    overview_table(h, targets, round);
  }
  for (const Json& t : targets) {
    const std::string id = text(t, {"id"});
    const long long round = round_of(t);
    h << "<section id=\"" << anchor(id, round) << "\">\n<h2>" << html_escape(id)
      << (round > 0 ? " (round " + std::to_string(round) + ")" : "") << " "
      << badge(text(t, {"outcome"})) << "</h2>\n";
    target_figures(h, t);
    target_pictures(h, id, run_dir);
    h << "</section>\n";
  }
  h << "<footer>Written by projtour from report.json in this directory.</footer>\n"
    << "</body>\n</html>\n";
  return h.str();
}

void write_summary_page(const SummaryInput& input, const std::filesystem::path& run_dir) {
  write_file_atomically(run_dir / "summary.html", render_summary_page(input, run_dir));
}

}  // namespace projtour
