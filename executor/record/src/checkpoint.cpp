#include "projtour/record/checkpoint.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <stdexcept>
#include <utility>

namespace projtour {

namespace {

using namespace json_field;

[[noreturn]] void bad(const std::string& path, const std::string& what) {
  throw std::runtime_error(path + ": " + what);
}

std::string json_quoted(const std::string& s) {
  // dump_json escapes control characters: a hostile id never reaches the terminal raw.
  return dump_json(Json(s));
}

std::string hex64(std::uint64_t value) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(value));
  return buf;
}

std::string fixed(double value, int precision) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", precision, value);
  return buf;
}

// Times are mission or wall seconds (milliseconds) of a tour that ran: never negative, never
// non-finite (a NaN written as null included), and never beyond what a tour could reach.
double time_at(const Json& object, const char* key, const std::string& path, double max) {
  const Json& v = required(object, key);
  if (v.is_number()) {
    const double t = v.get<double>();
    if (std::isfinite(t) && t >= 0.0 && t <= max) return t;
  } else if (!v.is_null()) {
    bad(path, std::string("is not a number but ") + v.type_name());
  }
  bad(path, "expected a finite time from 0 to " + json_number_text(max) + ", got " + dump_json(v));
}

void check_time(const Json& object, const char* key, const std::string& path, double max) {
  if (object.is_object() && object.contains(key)) time_at(object, key, path + "." + key, max);
}

void check_count(const Json& object, const char* key, const std::string& path) {
  if (object.contains(key) && object.at(key).is_number_integer() &&
      !object.at(key).is_number_unsigned()) {
    bad(path + "." + key, "expected a count >= 0, got " + dump_json(object.at(key)));
  }
}

template <int N>
Eigen::Matrix<double, N, 1> finite_numbers(const Json& object, const char* key,
                                           const std::string& path) {
  const Json& v = required(object, key);
  const std::string at = path + "." + key;
  if (!v.is_array() || v.size() != N) {
    bad(at, "expected an array of " + std::to_string(N) + " numbers");
  }
  Eigen::Matrix<double, N, 1> out;
  for (int i = 0; i < N; ++i) {
    const Json& x = v[static_cast<std::size_t>(i)];
    if (!x.is_number() || !std::isfinite(x.get<double>())) {
      bad(at + "[" + std::to_string(i) + "]", "expected a finite number, got " + dump_json(x));
    }
    out[i] = x.get<double>();
  }
  return out;
}

Json identity_to_json(const TargetIdentity& id) {
  Json pose = Json::object();
  pose["translation_m"] = {id.t_map_model_m.x(), id.t_map_model_m.y(), id.t_map_model_m.z()};
  pose["rotation_wxyz"] = {id.q_map_model.w(), id.q_map_model.x(), id.q_map_model.y(),
                           id.q_map_model.z()};
  Json model = Json::object();
  model["file"] = id.model;
  model["bytes"] = id.model_bytes;
  model["fnv1a64"] = hex64(id.model_fnv1a64);
  Json j = Json::object();
  j["pose"] = std::move(pose);
  j["model"] = std::move(model);
  return j;
}

TargetIdentity identity_from_json(const Json& j, const std::string& path) {
  const auto object_at = [](const Json& parent, const char* key, const std::string& at) {
    const Json& v = required(parent, key);
    if (!v.is_object()) bad(at, std::string("is not an object but ") + v.type_name());
    return std::cref(v);
  };
  if (!j.is_object()) bad(path, std::string("is not an object but ") + j.type_name());
  TargetIdentity id;
  try {
    reject_unknown(j, {"pose", "model"});
    const Json& pose = object_at(j, "pose", path + ".pose");
    reject_unknown(pose, {"translation_m", "rotation_wxyz"});
    id.t_map_model_m = finite_numbers<3>(pose, "translation_m", path + ".pose");
    const Eigen::Vector4d q = finite_numbers<4>(pose, "rotation_wxyz", path + ".pose");
    // Written from a rotation matrix, so a unit quaternion to the last digits; kept as written
    // so that the checkpoint reads back byte for byte.
    if (std::abs(q.norm() - 1.0) > 1e-9) {
      bad(path + ".pose.rotation_wxyz",
          "expected a unit quaternion, got norm " + json_number_text(q.norm()));
    }
    id.q_map_model = Eigen::Quaterniond(q[0], q[1], q[2], q[3]);
    const Json& model = object_at(j, "model", path + ".model");
    reject_unknown(model, {"file", "bytes", "fnv1a64"});
    id.model = string_at(model, "file");
    id.model_bytes = uint64_at(model, "bytes");
    const std::string hash = string_at(model, "fnv1a64");
    if (hash.size() != 16 || hash.find_first_not_of("0123456789abcdef") != std::string::npos) {
      bad(path + ".model.fnv1a64", "expected 16 lowercase hex digits, got " + json_quoted(hash));
    }
    id.model_fnv1a64 = std::stoull(hash, nullptr, 16);
  } catch (const std::runtime_error& e) {
    // json_field's messages name the key only: put the path in front of those.
    const std::string what = e.what();
    if (what.rfind(path, 0) == 0) throw;
    bad(path, what);
  }
  return id;
}

std::string read_bounded(const std::filesystem::path& file, std::uintmax_t max_bytes) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw std::runtime_error(file.string() + ": cannot read the checkpoint");
  std::string text;
  char buf[1 << 16];
  while (in.read(buf, sizeof buf) || in.gcount() > 0) {
    text.append(buf, static_cast<std::size_t>(in.gcount()));
    if (text.size() > max_bytes) {
      throw std::runtime_error(file.string() + ": larger than " + std::to_string(max_bytes >> 20) +
                               " MiB, the bound of a checkpoint");
    }
  }
  if (in.bad()) throw std::runtime_error(file.string() + ": cannot read the checkpoint");
  return text;
}

}  // namespace

TargetIdentity identify_target(const TargetSpec& target) {
  TargetIdentity id;
  id.t_map_model_m = target.T_map_model.translation();
  id.q_map_model = Eigen::Quaterniond(target.T_map_model.rotation());
  id.model = target.model.string();
  std::ifstream in(target.model, std::ios::binary);
  if (!in) throw std::runtime_error(target.model.string() + ": cannot read the model");
  // 64-bit FNV-1a: no library needed, and a changed model differs by chance only 1 in 2^64.
  std::uint64_t hash = 0xcbf29ce484222325ull;
  char buf[1 << 16];
  while (in.read(buf, sizeof buf) || in.gcount() > 0) {
    const auto n = static_cast<std::size_t>(in.gcount());
    for (std::size_t i = 0; i < n; ++i) {
      hash = (hash ^ static_cast<unsigned char>(buf[i])) * 0x100000001b3ull;
    }
    id.model_bytes += n;
  }
  if (in.bad()) throw std::runtime_error(target.model.string() + ": cannot read the model");
  id.model_fnv1a64 = hash;
  return id;
}

std::vector<TargetIdentity> identify_targets(const MissionSpec& mission) {
  std::vector<TargetIdentity> out;
  for (const auto& t : mission.targets) out.push_back(identify_target(t));
  return out;
}

std::string identity_change(const TargetIdentity& recorded, const TargetIdentity& now) {
  std::vector<std::string> changes;
  const double moved_m = (now.t_map_model_m - recorded.t_map_model_m).norm();
  if (moved_m > kIdentityTolerance_m) {
    changes.push_back("its pose on the map moved " + fixed(moved_m, 3) + " m");
  }
  const double turned_deg =
      recorded.q_map_model.angularDistance(now.q_map_model) * 180.0 / EIGEN_PI;
  if (turned_deg > kIdentityTolerance_deg) {
    changes.push_back("its pose on the map turned " + fixed(turned_deg, 3) + " deg");
  }
  if (now.model_bytes != recorded.model_bytes || now.model_fnv1a64 != recorded.model_fnv1a64) {
    changes.push_back("its model changed (" + json_quoted(recorded.model) + ", " +
                      std::to_string(recorded.model_bytes) + " bytes, fnv1a64 " +
                      hex64(recorded.model_fnv1a64) + "; now " + json_quoted(now.model) + ", " +
                      std::to_string(now.model_bytes) + " bytes, fnv1a64 " +
                      hex64(now.model_fnv1a64) + ")");
  }
  std::string out;
  for (const auto& c : changes) out += (out.empty() ? "" : " and ") + c;
  return out;
}

Json checkpoint_to_json(const Checkpoint& checkpoint) {
  if (checkpoint.done.size() != checkpoint.done_against.size()) {
    throw std::logic_error("checkpoint_to_json: each done target needs what it was done against");
  }
  Json j = Json::object();
  j["mission"] = checkpoint.mission;
  j["seed"] = checkpoint.seed;
  j["mission_s"] = checkpoint.mission_s;
  Json done = Json::array();
  for (std::size_t k = 0; k < checkpoint.done.size(); ++k) {
    Json record = checkpoint.done[k];
    record["done_against"] = identity_to_json(checkpoint.done_against[k]);
    done.push_back(std::move(record));
  }
  j["done"] = std::move(done);
  j["current_target"] = checkpoint.current_target ? Json(*checkpoint.current_target) : Json();
  if (checkpoint.round) j["round"] = *checkpoint.round;
  return j;
}

Checkpoint parse_checkpoint(const std::string& text, const std::string& source,
                            const MissionSpec& mission) {
  if (text.size() > kMaxCheckpointBytes) {
    throw std::runtime_error(source + ": larger than " + std::to_string(kMaxCheckpointBytes >> 20) +
                             " MiB, the bound of a checkpoint");
  }
  auto index_of = [&](const std::string& id, const std::string& path) {
    for (std::size_t i = 0; i < mission.targets.size(); ++i) {
      if (mission.targets[i].id == id) return i;
    }
    bad(path, "target " + json_quoted(id) + " is not in the mission");
  };
  // parse_json names the file itself.
  const Json j = parse_json(text, source);
  try {
    expect_object(j, "the checkpoint");
    reject_unknown(j, {"mission", "seed", "mission_s", "done", "current_target", "round"});
    Checkpoint c;
    c.mission = string_at(j, "mission");
    if (c.mission != mission.name) {
      throw std::runtime_error("written by mission " + json_quoted(c.mission) + ", not " +
                               json_quoted(mission.name));
    }
    c.seed = uint64_at(j, "seed");
    c.mission_s = time_at(j, "mission_s", "mission_s", kMaxCheckpointMissionS);
    if (j.contains("round")) {
      const Json& round = j.at("round");
      // The loader's bound on rounds (mission_loader.cpp kMaxRounds).
      if (!round.is_number_unsigned() || round.get<std::uint64_t>() < 1 ||
          round.get<std::uint64_t>() > 10000) {
        bad("round", "expected a round from 1 to 10000, got " + dump_json(round));
      }
      c.round = round.get<int>();
    }
    const Json& done = required(j, "done");
    if (!done.is_array()) throw std::runtime_error("\"done\" is not an array");
    // Where each target was first found done in each round, for the message naming a second.
    std::map<std::pair<std::size_t, int>, std::size_t> done_at;
    for (std::size_t k = 0; k < done.size(); ++k) {
      const std::string at = "done[" + std::to_string(k) + "]";
      Json entry = done[k];
      TargetIdentity against;
      if (entry.is_object()) {
        if (!entry.contains("done_against")) {
          bad(at + ".done_against", "missing: each done target records what it was done against");
        }
        against = identity_from_json(entry.at("done_against"), at + ".done_against");
        entry.erase("done_against");
      }
      TargetRecord r;
      try {
        r = entry.get<TargetRecord>();
      } catch (const std::runtime_error& e) {
        bad(at, e.what());
      }
      r.index = index_of(r.id, at + ".id");
      if (c.round ? r.round < 1 || r.round > *c.round : r.round != 0) {
        bad(at + ".round", c.round
                               ? "expected a round from 1 to the checkpoint's " +
                                     std::to_string(*c.round) + ", got " + std::to_string(r.round)
                               : "a round in a checkpoint without one");
      }
      const auto [first, inserted] = done_at.emplace(std::make_pair(r.index, r.round), k);
      if (!inserted) {
        bad(at + ".id", json_quoted(r.id) + " is done already (done[" +
                            std::to_string(first->second) + "]" +
                            (c.round ? " in round " + std::to_string(r.round) : "") + ")");
      }
      bool known = false;
      std::string expected;
      for (const char* o : kTargetOutcomes) {
        known = known || r.outcome == o;
        expected += (expected.empty() ? "" : ", ") + json_quoted(o);
      }
      if (!known)
        bad(at + ".outcome", "expected one of " + expected + ", got " + json_quoted(r.outcome));
      check_count(entry, "retries", at);
      check_count(entry, "beam_interruptions", at);
      constexpr double max_s = kMaxCheckpointMissionS, max_ms = kMaxCheckpointMissionS * 1e3;
      check_time(entry, "projected_s", at, max_s);
      check_time(entry, "blanked_s", at, max_s);
      if (entry.contains("align")) check_time(entry.at("align"), "time_ms", at + ".align", max_ms);
      if (entry.contains("calibration")) {
        const Json& calibration = entry.at("calibration");
        check_time(calibration, "sequence_s", at + ".calibration", max_s);
        check_time(calibration, "time_ms", at + ".calibration", max_ms);
      }
      c.done.push_back(std::move(r));
      c.done_against.push_back(against);
    }
    const Json& current = required(j, "current_target");
    if (!current.is_null()) {
      c.current_target = string_at(j, "current_target");
      index_of(*c.current_target, "current_target");
    }
    return c;
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(source + ": " + e.what());
  }
}

Checkpoint read_checkpoint(const std::filesystem::path& file, const MissionSpec& mission) {
  return parse_checkpoint(read_bounded(file, kMaxCheckpointBytes), file.string(), mission);
}

std::vector<std::string> drop_changed_targets(Checkpoint& checkpoint,
                                              const std::vector<TargetIdentity>& now) {
  if (checkpoint.done.size() != checkpoint.done_against.size()) {
    throw std::logic_error("drop_changed_targets: done and done_against differ in size");
  }
  std::vector<std::string> notes;
  std::vector<TargetRecord> kept;
  std::vector<TargetIdentity> kept_against;
  for (std::size_t k = 0; k < checkpoint.done.size(); ++k) {
    const TargetRecord& r = checkpoint.done[k];
    const std::string change = identity_change(checkpoint.done_against[k], now.at(r.index));
    if (change.empty()) {
      kept.push_back(r);
      kept_against.push_back(checkpoint.done_against[k]);
    } else {
      notes.push_back("target " + json_quoted(r.id) + " visited again: " + change +
                      " since the checkpoint");
    }
  }
  checkpoint.done = std::move(kept);
  checkpoint.done_against = std::move(kept_against);
  return notes;
}

}  // namespace projtour
