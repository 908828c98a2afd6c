#include "projtour/ros2/dds.hpp"

#include <map>
#include <mutex>

namespace projtour::ros2 {

namespace {

// Cyclone keeps one configuration per domain and process: the first participant's choice holds
// until the last of them goes.
struct Domain {
  int id = 0;
  bool loopback_only = false;
  dds_entity_t entity = 0;  // 0 when Cyclone made the domain itself (its own configuration)
  ~Domain() {
    if (entity > 0) dds_delete(entity);
  }
};

std::mutex& registry_mutex() {
  static std::mutex m;
  return m;
}

std::map<int, std::weak_ptr<Domain>>& registry() {
  static std::map<int, std::weak_ptr<Domain>> r;
  return r;
}

std::shared_ptr<Domain> attach_domain(const NetworkSpec& network) {
  std::lock_guard<std::mutex> lock(registry_mutex());
  auto& slot = registry()[network.domain_id];
  if (auto existing = slot.lock()) {
    if (existing->loopback_only != network.loopback_only) {
      throw DdsError("DDS domain " + std::to_string(network.domain_id) +
                     " is already open in this process " +
                     (existing->loopback_only ? "on loopback only" : "with Cyclone's own network") +
                     "; one process cannot hold both configurations");
    }
    return existing;
  }
  auto domain = std::make_shared<Domain>();
  domain->id = network.domain_id;
  domain->loopback_only = network.loopback_only;
  if (network.loopback_only) {
    const std::string xml = loopback_config();
    domain->entity =
        check(dds_create_domain(static_cast<dds_domainid_t>(network.domain_id), xml.c_str()),
              "creating DDS domain " + std::to_string(network.domain_id) + " on loopback");
  }
  slot = domain;
  return domain;
}

}  // namespace

dds_return_t check(dds_return_t rc, const std::string& what) {
  if (rc < 0) throw DdsError(what + ": " + dds_strretcode(rc));
  return rc;
}

std::string loopback_config() {
  // lo has no MULTICAST flag, so discovery goes by unicast to the participant ports of
  // 127.0.0.1 (indices 0..MaxAutoParticipantIndex, one per process on the domain).
  return "<CycloneDDS><Domain Id=\"any\">"
         "<General><Interfaces><NetworkInterface name=\"lo\"/></Interfaces>"
         "<AllowMulticast>false</AllowMulticast></General>"
         "<Discovery><ParticipantIndex>auto</ParticipantIndex>"
         "<MaxAutoParticipantIndex>30</MaxAutoParticipantIndex>"
         "<Peers><Peer address=\"127.0.0.1\"/></Peers></Discovery>"
         "</Domain></CycloneDDS>";
}

std::string dds_topic_name(const std::string& ros2_namespace, const std::string& name) {
  if (!name.empty() && name.front() == '/') return "rt" + name;
  return "rt" + ros2_namespace + "/" + name;
}

Participant::Participant(const NetworkSpec& network, const std::string& node_name)
    : network_(network) {
  domain_ = attach_domain(network);
  dds_qos_t* qos = dds_create_qos();
  // ROS 2 nodes announce "enclave=/;" in their user data; dashboards list participants by it.
  const std::string user_data = "enclave=/;name=" + node_name + ";";
  dds_qset_userdata(qos, user_data.data(), user_data.size());
  participant_ =
      dds_create_participant(static_cast<dds_domainid_t>(network.domain_id), qos, nullptr);
  dds_delete_qos(qos);
  check(participant_, "creating a DDS participant on domain " + std::to_string(network.domain_id));
  publications_ =
      dds_create_reader(participant_, DDS_BUILTIN_TOPIC_DCPSPUBLICATION, nullptr, nullptr);
  if (publications_ < 0) {
    dds_delete(participant_);
    check(publications_, "reading DDS's built-in publications topic");
  }
}

Participant::~Participant() {
  if (participant_ > 0) dds_delete(participant_);  // and everything created under it
}

std::vector<std::string> Participant::published_types(const std::string& dds_topic) const {
  std::vector<std::string> types;
  constexpr int kBatch = 64;
  void* samples[kBatch] = {nullptr};
  dds_sample_info_t infos[kBatch];
  const dds_return_t n = dds_read(publications_, samples, infos, kBatch, kBatch);
  if (n < 0) return types;
  for (dds_return_t i = 0; i < n; ++i) {
    if (!infos[i].valid_data) continue;
    const auto* e = static_cast<const dds_builtintopic_endpoint_t*>(samples[i]);
    if (e->topic_name != nullptr && dds_topic == e->topic_name && e->type_name != nullptr) {
      types.emplace_back(e->type_name);
    }
  }
  dds_return_loan(publications_, samples, n);
  return types;
}

namespace detail {

namespace {
dds_qos_t* make_qos(const QosProfile& profile) {
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos,
                       profile.reliable ? DDS_RELIABILITY_RELIABLE : DDS_RELIABILITY_BEST_EFFORT,
                       DDS_MSECS(100));
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, profile.depth);
  dds_qset_durability(
      qos, profile.transient_local ? DDS_DURABILITY_TRANSIENT_LOCAL : DDS_DURABILITY_VOLATILE);
  // ROS 2 (rmw_cyclonedds) speaks XCDR1; say so rather than rely on Cyclone's default.
  const dds_data_representation_id_t xcdr1 = DDS_DATA_REPRESENTATION_XCDR1;
  dds_qset_data_representation(qos, 1, &xcdr1);
  return qos;
}
}  // namespace

dds_entity_t create_topic(const Participant& p, const dds_topic_descriptor_t& type,
                          const std::string& dds_topic) {
  return check(dds_create_topic(p.handle(), &type, dds_topic.c_str(), nullptr, nullptr),
               "creating topic " + dds_topic + " of type " + type.m_typename);
}

dds_entity_t create_writer(const Participant& p, dds_entity_t topic, const QosProfile& qos,
                           const std::string& dds_topic) {
  dds_qos_t* q = make_qos(qos);
  const dds_entity_t w = dds_create_writer(p.handle(), topic, q, nullptr);
  dds_delete_qos(q);
  return check(w, "creating a writer on " + dds_topic);
}

dds_entity_t create_reader(const Participant& p, dds_entity_t topic, const QosProfile& qos,
                           const std::string& dds_topic) {
  dds_qos_t* q = make_qos(qos);
  const dds_entity_t r = dds_create_reader(p.handle(), topic, q, nullptr);
  dds_delete_qos(q);
  return check(r, "creating a reader on " + dds_topic);
}

void delete_entity(dds_entity_t e) {
  if (e > 0) dds_delete(e);
}

int matched_count(dds_entity_t endpoint, bool is_writer) {
  if (is_writer) {
    dds_publication_matched_status_t st;
    if (dds_get_publication_matched_status(endpoint, &st) < 0) return 0;
    return static_cast<int>(st.current_count);
  }
  dds_subscription_matched_status_t st;
  if (dds_get_subscription_matched_status(endpoint, &st) < 0) return 0;
  return static_cast<int>(st.current_count);
}

}  // namespace detail

}  // namespace projtour::ros2
