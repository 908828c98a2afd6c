// The run's recorder into the history database (history_recorder.hpp).
#include "history_recorder.hpp"

#include <sys/stat.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <ostream>
#include <random>

#include "projtour/record/target_record.hpp"
#include "projtour/tour/history_proof.hpp"

namespace projtour {

namespace {

double wall_unix_s() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

// A random (version 4) UUID: a run's id must not collide across robots sharing one database.
std::string new_uuid() {
  std::random_device device;
  unsigned char b[16];
  for (int i = 0; i < 16; i += 4) {
    const std::uint32_t r = device();
    for (int k = 0; k < 4; ++k) b[i + k] = static_cast<unsigned char>(r >> (8 * k));
  }
  b[6] = static_cast<unsigned char>((b[6] & 0x0f) | 0x40);
  b[8] = static_cast<unsigned char>((b[8] & 0x3f) | 0x80);
  char text[37];
  std::snprintf(text, sizeof text,
                "%02x%02x%02x%02x-%02x%02x-%02x%02x-%02x%02x-%02x%02x%02x%02x%02x%02x", b[0], b[1],
                b[2], b[3], b[4], b[5], b[6], b[7], b[8], b[9], b[10], b[11], b[12], b[13], b[14],
                b[15]);
  return text;
}

// The file's modification time as Unix seconds; nullopt when it cannot be read.
std::optional<double> modified_unix_s(const std::filesystem::path& file) {
  struct stat st {};
  if (::stat(file.c_str(), &st) != 0) return std::nullopt;
  return static_cast<double>(st.st_mtim.tv_sec) + 1e-9 * static_cast<double>(st.st_mtim.tv_nsec);
}

}  // namespace

std::vector<unsigned char> proof_jpeg_from(const std::filesystem::path& picture, int width_px) {
  const cv::Mat image = cv::imread(picture.string(), cv::IMREAD_COLOR);
  if (image.empty()) return {};
  cv::Mat small = image;
  if (image.cols > width_px) {
    const int height = std::max(1, image.rows * width_px / image.cols);
    cv::resize(image, small, cv::Size(width_px, height), 0, 0, cv::INTER_AREA);
  }
  std::vector<unsigned char> jpeg;
  cv::imencode(".jpg", small, jpeg, {cv::IMWRITE_JPEG_QUALITY, 80});
  return jpeg;
}

std::unique_ptr<HistoryRecorder> HistoryRecorder::start(const RunOptions& options,
                                                        const MissionSpec& mission,
                                                        const std::filesystem::path& run_dir,
                                                        std::uint64_t seed, const Clock& clock,
                                                        std::ostream& err) {
  if (options.no_history) return nullptr;
  std::unique_ptr<HistoryRecorder> recorder(new HistoryRecorder(clock, err));
  recorder->mission_ = &mission;
  const std::filesystem::path file = options.history ? *options.history : default_history_path();
  recorder->file_ = file;
  if (file.empty()) {
    recorder->fail("no history file: neither XDG_DATA_HOME nor HOME is set (--history FILE)");
    return recorder;
  }
  std::error_code ec;
  recorder->run_dir_ = std::filesystem::weakly_canonical(run_dir, ec);
  if (ec) recorder->run_dir_ = std::filesystem::absolute(run_dir);
  try {
    recorder->db_ = std::make_unique<HistoryDb>(file, HistoryAccess::read_write);
    std::optional<HistoryRun> earlier;
    if (options.resume) earlier = recorder->db_->find_run_by_dir(recorder->run_dir_.string());
    if (earlier) {
      recorder->run_ = *earlier;
    } else {
      recorder->run_.id = new_uuid();
      recorder->run_.mission = mission.name;
      recorder->run_.robot = mission.robot_file.stem().string();
      recorder->run_.run_dir = recorder->run_dir_.string();
      // Mission time 0 (a resumed clock starts past it).
      recorder->run_.started_at_s = wall_unix_s() - clock.now_s();
      recorder->run_.dry_run = options.dry_run;
      recorder->run_.seed = seed;
    }
    recorder->run_.outcome = "running";
    recorder->dry_base_unix_s_ = recorder->run_.started_at_s;
    recorder->db_->upsert_run(recorder->run_);
  } catch (const std::exception& e) {
    recorder->fail(e.what());
  }
  return recorder;
}

void HistoryRecorder::fail(const std::string& what) {
  db_.reset();
  std::lock_guard<std::mutex> lock(note_mutex_);
  if (!note_.empty()) return;
  note_ = "history: not recorded from here on: " + what;
  err_ << "projtour: warning: " << note_ << "\n";
}

double HistoryRecorder::unix_at(double mission_s) const {
  return run_.dry_run ? dry_base_unix_s_ + mission_s : wall_unix_s();
}

void HistoryRecorder::on_event(const ExecutorEvent& event) {
  if (!db_ || event.type != EventType::enter || !event.target) return;
  if (visiting_ && *visiting_ == *event.target) return;
  visiting_ = *event.target;
  visit_start_unix_s_ = unix_at(event.t_s);
  visit_start_wall_s_ = wall_unix_s();
}

void HistoryRecorder::on_target_done(const TargetRecord& record) {
  const bool visited = visiting_ && *visiting_ == record.id;
  visiting_.reset();
  if (!db_) return;
  HistoryVisit v;
  v.run_id = run_.id;
  v.round = record.round;
  v.target = record.id;
  v.content = record.content;
  // A target with one content has no list item in its record: the file is its content.
  if (v.content.empty() && record.index < mission_->targets.size()) {
    v.content = mission_->targets[record.index].content.filename().string();
  }
  v.ended_at_s = unix_at(clock_.now_s());
  // A target passed over for its hours has no visit of its own: it starts as it ends.
  v.started_at_s = visited ? visit_start_unix_s_ : v.ended_at_s;
  const TargetMeasurements& m = record.measurements;
  v.shown_s = m.projected_s.value_or(0.0);
  v.blanked_s = m.blanked_s.value_or(0.0);
  v.observed_error_mm = m.observed_error_mm;
  if (m.projection_error_mm) v.true_error_mm = m.projection_error_mm->after_align;
  v.outcome = record.outcome;
  v.reason = record.reason;
  try {
    if (record.outcome == "projected" && visited) {
      // verify's own picture of the check (colour frame, expected and observed corners), made in
      // this visit: one left from an earlier round is older than the visit.
      const std::filesystem::path view = run_dir_ / "targets" / record.id / "camera_view.png";
      const std::optional<double> modified = modified_unix_s(view);
      if (modified && *modified + 1.0 >= visit_start_wall_s_) {
        const std::vector<unsigned char> jpeg = proof_jpeg_from(view);
        if (!jpeg.empty()) {
          const StoredProof proof = store_proof(db_->file(), jpeg);
          v.proof_path = proof.relative_path;
          v.proof_sha256 = proof.sha256;
        }
      }
    }
    db_->record_visit(v);
  } catch (const std::exception& e) {
    fail(e.what());
  }
}

void HistoryRecorder::finish(const std::string& outcome, std::vector<std::string>& notes) {
  if (db_) {
    run_.outcome = outcome;
    run_.ended_at_s = unix_at(clock_.now_s());
    try {
      db_->upsert_run(run_);
    } catch (const std::exception& e) {
      fail(e.what());
    }
  }
  std::lock_guard<std::mutex> lock(note_mutex_);
  if (!note_.empty()) notes.push_back(note_);
}

void HistoryRecorder::finish_after_hang(const std::string& outcome, double mission_s,
                                        std::vector<std::string>& notes, int busy_timeout_ms) {
  std::lock_guard<std::mutex> lock(note_mutex_);
  // A recording already ended has said so; its row is as its last write left it.
  if (note_.empty()) {
    HistoryRun run = run_;
    run.outcome = outcome;
    run.ended_at_s = unix_at(mission_s);
    try {
      HistoryDb(file_, HistoryAccess::read_write, busy_timeout_ms).upsert_run(run);
    } catch (const std::exception& e) {
      note_ = std::string("history: the run's end not recorded: ") + e.what();
      err_ << "projtour: warning: " << note_ << "\n";
    }
  }
  if (!note_.empty()) notes.push_back(note_);
}

}  // namespace projtour
