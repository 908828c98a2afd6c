#pragma once
// A thin C++ layer over Cyclone DDS's C API with ROS 2's conventions: "rt" + the topic's full
// name, the QoS of ROS 2's profiles, XCDR1, types from the project's IDL (messages.hpp).
// Every failure of the C API becomes a DdsError naming what was being done and Cyclone's reason.
#include <dds/dds.h>

#include <algorithm>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace projtour::ros2 {

class DdsError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct QosProfile {
  bool reliable = true;
  int depth = 10;
  // Late joiners get the last `depth` samples: ROS 2's "transient local", for status topics.
  bool transient_local = false;
};

// How a participant reaches others. Loopback: the `lo` interface only and unicast discovery to
// 127.0.0.1 (lo carries no multicast), so nothing a test or a simulation sends leaves the
// machine. Otherwise Cyclone's own configuration (CYCLONEDDS_URI, else its defaults).
struct NetworkSpec {
  int domain_id = 0;
  bool loopback_only = false;
};

// The Cyclone XML for a loopback-only domain.
std::string loopback_config();

// A participant on a domain. The first participant of a process on a domain creates the domain
// with its network configuration; later ones must ask for the same (else DdsError), since
// Cyclone keeps one configuration per domain and process.
class Participant {
 public:
  explicit Participant(const NetworkSpec& network, const std::string& node_name = "projtour");
  ~Participant();
  Participant(const Participant&) = delete;
  Participant& operator=(const Participant&) = delete;

  dds_entity_t handle() const { return participant_; }
  const NetworkSpec& network() const { return network_; }

  // The type names the domain's writers (other participants' included) announce on a topic
  // (its DDS name, "rt/..."), from Cyclone's built-in DCPSPublication topic: what a reader
  // that hears nothing can say about why.
  std::vector<std::string> published_types(const std::string& dds_topic) const;

 private:
  NetworkSpec network_;
  std::shared_ptr<void> domain_;  // the process-wide domain, released with its last participant
  dds_entity_t participant_ = 0;
  dds_entity_t publications_ = 0;  // reader of DCPSPublication
};

// "rt" + the full ROS 2 name: a relative name goes under the namespace ("" or "/ud1").
std::string dds_topic_name(const std::string& ros2_namespace, const std::string& name);

// Checks a C API return code (negative is an error).
dds_return_t check(dds_return_t rc, const std::string& what);

namespace detail {
dds_entity_t create_topic(const Participant& p, const dds_topic_descriptor_t& type,
                          const std::string& dds_topic);
dds_entity_t create_writer(const Participant& p, dds_entity_t topic, const QosProfile& qos,
                           const std::string& dds_topic);
dds_entity_t create_reader(const Participant& p, dds_entity_t topic, const QosProfile& qos,
                           const std::string& dds_topic);
void delete_entity(dds_entity_t e);
int matched_count(dds_entity_t endpoint, bool is_writer);
}  // namespace detail

// Writes samples of the generated C type T (described by `type`) on one topic.
template <typename T>
class Writer {
 public:
  Writer(const Participant& p, const dds_topic_descriptor_t& type, std::string dds_topic,
         const QosProfile& qos)
      : name_(std::move(dds_topic)) {
    topic_ = detail::create_topic(p, type, name_);
    writer_ = detail::create_writer(p, topic_, qos, name_);
  }
  ~Writer() {
    detail::delete_entity(writer_);
    detail::delete_entity(topic_);
  }
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;

  void write(const T& sample) { check(dds_write(writer_, &sample), "writing " + name_); }
  // Readers matched now (discovery done): for waiting in tests and for the status page.
  int matched() const { return detail::matched_count(writer_, true); }
  const std::string& topic() const { return name_; }

 private:
  std::string name_;
  dds_entity_t topic_ = 0;
  dds_entity_t writer_ = 0;
};

// Takes samples of T. The samples are Cyclone's loans, valid only inside the callback.
template <typename T>
class Reader {
 public:
  Reader(const Participant& p, const dds_topic_descriptor_t& type, std::string dds_topic,
         const QosProfile& qos)
      : name_(std::move(dds_topic)) {
    topic_ = detail::create_topic(p, type, name_);
    reader_ = detail::create_reader(p, topic_, qos, name_);
  }
  ~Reader() {
    detail::delete_entity(reader_);
    detail::delete_entity(topic_);
  }
  Reader(const Reader&) = delete;
  Reader& operator=(const Reader&) = delete;

  // Calls f(const T&, const dds_sample_info_t&) for every valid sample waiting, oldest first,
  // taking at most `max_samples` (a flood is drained over several calls, never all at once);
  // returns how many it took.
  template <typename F>
  int take(F&& f, int max_samples = 64) {
    constexpr int kBatch = 16;
    int taken = 0;
    while (taken < max_samples) {
      void* samples[kBatch] = {nullptr};
      dds_sample_info_t infos[kBatch];
      const int want = std::min(kBatch, max_samples - taken);
      const dds_return_t n = check(
          dds_take(reader_, samples, infos, static_cast<size_t>(want), static_cast<uint32_t>(want)),
          "taking from " + name_);
      const Loan loan{reader_, samples, n};  // given back even when f throws
      for (dds_return_t i = 0; i < n; ++i) {
        if (infos[i].valid_data) f(*static_cast<const T*>(samples[i]), infos[i]);
      }
      taken += n;
      if (n < want) break;
    }
    return taken;
  }
  int matched() const { return detail::matched_count(reader_, false); }
  const std::string& topic() const { return name_; }
  dds_entity_t handle() const { return reader_; }

 private:
  struct Loan {
    dds_entity_t reader;
    void** samples;
    dds_return_t n;
    ~Loan() {
      if (n > 0) dds_return_loan(reader, samples, n);
    }
  };
  std::string name_;
  dds_entity_t topic_ = 0;
  dds_entity_t reader_ = 0;
};

}  // namespace projtour::ros2
