#include "dds_endpoints.hpp"

#include <cstdlib>
#include <cstring>

#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl::ros2_node {
namespace {

struct QosHandle {
  dds_qos_t* qos = dds_create_qos();
  ~QosHandle() { dds_delete_qos(qos); }
};

void fill(const Qos& q, dds_qos_t* qos) {
  dds_qset_writer_data_lifecycle(qos, false);
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, q.depth);
  dds_qset_reliability(qos, q.reliable ? DDS_RELIABILITY_RELIABLE : DDS_RELIABILITY_BEST_EFFORT,
                       q.reliable ? DDS_INFINITY : 0);
  if (q.transient_local) {
    dds_qset_durability(qos, DDS_DURABILITY_TRANSIENT_LOCAL);
    dds_qset_durability_service(qos, 0, DDS_HISTORY_KEEP_LAST, q.depth, DDS_LENGTH_UNLIMITED, DDS_LENGTH_UNLIMITED,
                                DDS_LENGTH_UNLIMITED);
  } else {
    dds_qset_durability(qos, DDS_DURABILITY_VOLATILE);
  }
  if (!q.user_data.empty()) dds_qset_userdata(qos, q.user_data.data(), q.user_data.size());
}

dds_entity_t topic_of(dds_entity_t participant, const dds_topic_descriptor_t& type, const std::string& name) {
  const dds_entity_t topic = dds_create_topic(participant, &type, name.c_str(), nullptr, nullptr);
  if (topic < 0) {
    throw Error("cannot create DDS topic " + name + " (" + type.m_typename + "): " + dds_strretcode(topic));
  }
  return topic;
}

}  // namespace

Reader::Reader(dds_entity_t participant, const dds_topic_descriptor_t& type, const std::string& topic, const Qos& qos)
    : type_(type) {
  QosHandle q;
  fill(qos, q.qos);
  reader_ = dds_create_reader(participant, topic_of(participant, type, topic), q.qos, nullptr);
  if (reader_ < 0) throw Error("cannot read DDS topic " + topic + ": " + dds_strretcode(reader_));
}

Sample Reader::take() const {
  const dds_topic_descriptor_t* type = &type_;
  for (;;) {
    // Cyclone deserializes into our sample, allocating its sequences and strings; dds_sample_free releases them.
    void* memory = dds_alloc(type_.m_size);
    if (!memory) throw Error(std::string("out of memory for a sample of ") + type_.m_typename);
    std::memset(memory, 0, type_.m_size);  // a zeroed sample: no sequence or string to free yet
    Sample sample(memory, [type](void* p) { dds_sample_free(p, type, DDS_FREE_ALL); });
    void* buffers[1] = {sample.get()};
    dds_sample_info_t info;
    if (dds_take(reader_, buffers, &info, 1, 1) <= 0) return nullptr;
    if (info.valid_data) return sample;
  }
}

Writer::Writer(dds_entity_t participant, const dds_topic_descriptor_t& type, const std::string& topic, const Qos& qos)
    : topic_(topic) {
  QosHandle q;
  fill(qos, q.qos);
  writer_ = dds_create_writer(participant, topic_of(participant, type, topic), q.qos, nullptr);
  if (writer_ < 0) throw Error("cannot write DDS topic " + topic + ": " + dds_strretcode(writer_));
}

void Writer::write(const void* sample) const {
  const dds_return_t rc = dds_write(writer_, sample);
  if (rc < 0) throw Error("cannot write a sample to " + topic_ + ": " + dds_strretcode(rc));
}

int Writer::matched() const {
  dds_publication_matched_status_t status;
  return dds_get_publication_matched_status(writer_, &status) == 0 ? static_cast<int>(status.current_count) : 0;
}

bool wait_for_matched(dds_entity_t participant, dds_entity_t entity, int count, std::chrono::milliseconds timeout) {
  const auto current = [entity] {
    dds_publication_matched_status_t pub;
    if (dds_get_publication_matched_status(entity, &pub) == 0) return static_cast<int>(pub.current_count);
    dds_subscription_matched_status_t sub;
    if (dds_get_subscription_matched_status(entity, &sub) == 0) return static_cast<int>(sub.current_count);
    return 0;
  };
  const dds_entity_t waitset = dds_create_waitset(participant);
  dds_publication_matched_status_t probe;
  const bool writer = dds_get_publication_matched_status(entity, &probe) == DDS_RETCODE_OK;
  const std::uint32_t mask = writer ? DDS_PUBLICATION_MATCHED_STATUS : DDS_SUBSCRIPTION_MATCHED_STATUS;
  std::uint32_t old_mask = 0;
  dds_get_status_mask(entity, &old_mask);
  dds_set_status_mask(entity, old_mask | mask);
  dds_waitset_attach(waitset, entity, 0);
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  bool ok = current() >= count;
  while (!ok && std::chrono::steady_clock::now() < deadline) {
    const auto left = std::chrono::duration_cast<std::chrono::nanoseconds>(deadline - std::chrono::steady_clock::now());
    dds_waitset_wait(waitset, nullptr, 0, left.count());
    std::uint32_t triggered = 0;
    dds_take_status(entity, &triggered, mask);  // resets the status, so the next wait blocks until it changes
    ok = current() >= count;
  }
  dds_waitset_detach(waitset, entity);
  dds_set_status_mask(entity, old_mask);
  dds_delete(waitset);
  return ok;
}

MessageLoop::MessageLoop(dds_entity_t participant, std::function<void(const std::string&)> on_error)
    : participant_(participant), on_error_(std::move(on_error)) {
  waitset_ = dds_create_waitset(participant);
  guard_ = dds_create_guardcondition(participant);
  dds_waitset_attach(waitset_, guard_, -1);
}

MessageLoop::~MessageLoop() {
  stop_ = true;
  dds_set_guardcondition(guard_, true);
  if (thread_.joinable()) thread_.join();
  for (const dds_entity_t c : conditions_) dds_delete(c);
  dds_delete(guard_);
  dds_delete(waitset_);
}

void MessageLoop::add(const Reader& reader, std::function<void(const Sample&)> handler) {
  const dds_entity_t condition = dds_create_readcondition(reader.handle(), DDS_ANY_STATE);
  conditions_.push_back(condition);
  dds_waitset_attach(waitset_, condition, static_cast<dds_attach_t>(entries_.size()));
  entries_.push_back({&reader, std::move(handler)});
}

void MessageLoop::start() {
  thread_ = std::thread([this] { run(); });
}

void MessageLoop::run() {
  std::vector<dds_attach_t> triggered(entries_.size() + 1);
  while (!stop_) {
    const dds_return_t n = dds_waitset_wait(waitset_, triggered.data(), triggered.size(), DDS_INFINITY);
    for (dds_return_t i = 0; i < n && !stop_; ++i) {
      if (triggered[static_cast<std::size_t>(i)] < 0) continue;  // the guard
      Entry& e = entries_[static_cast<std::size_t>(triggered[static_cast<std::size_t>(i)])];
      while (const Sample s = e.reader->take()) {
        try {
          e.handler(s);
        } catch (const std::exception& error) {
          on_error_(std::string(e.reader->type().m_typename) + ": " + error.what());
        }
      }
    }
  }
}

}  // namespace tsdf_mcl::ros2_node
