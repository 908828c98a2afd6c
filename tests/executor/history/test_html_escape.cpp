// The one HTML escaper (html_escape.hpp) and the pages that use it: the history page escaped
// every character the summary page did but `'`.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "projtour/formats/html_escape.hpp"
#include "projtour/history/history.hpp"
#include "projtour_test/temp_dir.hpp"

namespace projtour {
namespace {

namespace fs = std::filesystem;

TEST(HtmlEscape, EscapesTheFiveCharactersThatCanEndTextOrAnAttribute) {
  EXPECT_EQ(html_escape(R"(a&b<c>d"e'f)"), "a&amp;b&lt;c&gt;d&quot;e&#39;f");
  // An entity already written is text like any other: escaped again, not passed through.
  EXPECT_EQ(html_escape("&amp;"), "&amp;amp;");
  EXPECT_EQ(html_escape("pillar 2 · menü.png"), "pillar 2 · menü.png");
  EXPECT_EQ(html_escape(""), "");
}

TEST(HtmlEscape, Regression_TheHistoryPageEscapesASingleQuote) {
  test::TempDir dir;
  const fs::path file = dir.path() / "h.sqlite";
  HistoryDb db(file, HistoryAccess::read_write);
  HistoryRun run;
  run.id = "r1";
  run.mission = "m";
  run.robot = "ud";
  run.run_dir = "/runs/r1";
  run.started_at_s = 1.7e9;
  run.dry_run = false;
  db.upsert_run(run);
  HistoryVisit v;
  v.run_id = "r1";
  v.round = 1;
  v.target = "Ada's door";
  v.content = "Ada's <menu>.png";
  v.started_at_s = 1.7e9;
  v.ended_at_s = 1.7e9 + 20.0;
  v.shown_s = 10.0;
  v.blanked_s = 1.5;
  v.observed_error_mm = 1.0;
  v.true_error_mm = 0.5;
  v.outcome = "projected";
  // A proof, so that the page has its figure (alt and caption); its bytes need not be an image.
  const StoredProof proof = store_proof(file, {0xff, 0xd8, 0xff, 0xe0, 1, 2, 3});
  v.proof_path = proof.relative_path;
  v.proof_sha256 = proof.sha256;
  db.record_visit(v);

  const fs::path page = dir.path() / "history.html";
  write_history_page(db, HistoryQuery{}, page);
  std::ifstream in(page);
  std::ostringstream text;
  text << in.rdbuf();
  const std::string html = text.str();
  // In the totals' attribute and cell, the calendar's heading, the proof's alt and caption.
  EXPECT_NE(html.find("<tr data-content=\"Ada&#39;s &lt;menu&gt;.png\"><td>Ada&#39;s "
                      "&lt;menu&gt;.png</td>"),
            std::string::npos)
      << html;
  EXPECT_NE(html.find("<th>Ada&#39;s &lt;menu&gt;.png</th>"), std::string::npos) << html;
  EXPECT_NE(html.find("alt=\"Ada&#39;s &lt;menu&gt;.png on Ada&#39;s door\""), std::string::npos)
      << html;
  EXPECT_NE(html.find("<figcaption>Ada&#39;s &lt;menu&gt;.png on Ada&#39;s door, "),
            std::string::npos)
      << html;
  EXPECT_EQ(html.find("Ada's"), std::string::npos) << html;
}

}  // namespace
}  // namespace projtour
