#include "projtour/views/ros2_status.hpp"

#include <algorithm>

#include "projtour/contract/blackboard_keys.hpp"
#include "projtour/formats/json_io.hpp"
#include "projtour/ros2/dds.hpp"
#include "projtour/ros2/messages.hpp"

namespace projtour {

using namespace ros2;

namespace {
constexpr QosProfile kLatest{true, 1, true};
}  // namespace

struct Ros2Status::Impl {
  Impl(const Executor& e, const RunContext& r)
      : executor(e),
        run(r),
        spec(r.mission->robot.ros2),
        participant(network_of(spec), "projtour"),
        state(participant, std_msgs_msg_dds__String__desc,
              dds_topic_name(spec.ros2_namespace, "projtour/state"), kLatest),
        target(participant, std_msgs_msg_dds__String__desc,
               dds_topic_name(spec.ros2_namespace, "projtour/target"), kLatest),
        pose(participant, geometry_msgs_msg_dds__PoseWithCovarianceStamped__desc,
             dds_topic_name(spec.ros2_namespace, "projtour/pose"), {true, 10, true}),
        projector(participant, std_msgs_msg_dds__Bool__desc,
                  dds_topic_name(spec.ros2_namespace, "projtour/projector_lit"), kLatest),
        // One sample per finished visit; a late joiner gets the whole tour so far.
        results(participant, std_msgs_msg_dds__String__desc,
                dds_topic_name(spec.ros2_namespace, "projtour/results"),
                {true, static_cast<int>(std::max<std::size_t>(1, r.mission->targets.size())) * 4,
                 true}) {}

  void write_string(Writer<std_msgs_msg_dds__String_>& w, const std::string& text) {
    std_msgs_msg_dds__String_ msg{};
    std::string copy = text;
    msg.data = copy.data();
    w.write(msg);
  }

  const Executor& executor;
  const RunContext& run;
  const Ros2Spec spec;
  Participant participant;
  Writer<std_msgs_msg_dds__String_> state;
  Writer<std_msgs_msg_dds__String_> target;
  Writer<geometry_msgs_msg_dds__PoseWithCovarianceStamped_> pose;
  Writer<std_msgs_msg_dds__Bool_> projector;
  Writer<std_msgs_msg_dds__String_> results;
  std::optional<std::string> last_state, last_target;
  std::optional<bool> last_lit;
  double last_pose_t_s = -1.0;
  std::size_t records_sent = 0;
  std::string last_record_outcome;
};

Ros2Status::Ros2Status(const Executor& executor, const RunContext& run)
    : impl_(std::make_unique<Impl>(executor, run)) {}

Ros2Status::~Ros2Status() = default;

void Ros2Status::publish() {
  Impl& s = *impl_;
  std::string state = s.executor.active_state();
  if (s.executor.finished()) state = std::string("finished:") + to_string(s.executor.outcome());
  if (state != s.last_state) {
    s.write_string(s.state, state);
    s.last_state = state;
  }
  std::string target;
  if (const auto t = s.executor.current_target()) target = s.run.mission->targets[*t].id;
  if (target != s.last_target) {
    s.write_string(s.target, target);
    s.last_target = target;
  }
  if (const PoseEstimate2D* e = s.run.blackboard->find(keys::kLocalization)) {
    if (e->t_s != s.last_pose_t_s) {
      PoseMessage msg;
      fill_pose(*e, msg);
      s.pose.write(msg.msg);
      s.last_pose_t_s = e->t_s;
    }
  }
  if (s.run.drivers != nullptr && s.run.drivers->projector) {
    const bool lit = !s.run.drivers->projector->is_blank();
    if (lit != s.last_lit) {
      std_msgs_msg_dds__Bool_ msg{lit};
      s.projector.write(msg);
      s.last_lit = lit;
    }
  }
  // Records are appended to, or a retry takes its target's out: send what is new, and the last
  // again when its outcome changed.
  const auto& records = s.executor.records();
  if (records.size() < s.records_sent) s.records_sent = records.size();
  for (std::size_t i = s.records_sent; i < records.size(); ++i) {
    s.write_string(s.results, Json(records[i]).dump());
  }
  s.records_sent = records.size();
}

bool wants_ros2_status(const RunContext& run, const std::vector<std::string>& driver_kinds) {
  const Ros2Spec& spec = run.mission->robot.ros2;
  const bool ros2_robot =
      spec.present || std::any_of(driver_kinds.begin(), driver_kinds.end(),
                                  [](const auto& k) { return k.rfind("ros2_", 0) == 0; });
  return ros2_robot && spec.publish_status;
}

}  // namespace projtour
