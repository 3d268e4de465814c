// Every difference between Fast DDS 2.x (libfastrtps: Humble's 2.6 to Jazzy's 2.14, Debian's 2.9) and 3.x
// (libfastdds: Kilted's 3.2) that the shim meets, in one place (issue 21). build.rs defines XF_FASTDDS_MAJOR
// from the headers it found; xfast.cpp is written against the names below only.
//
// What changed in 3.x, as the shim sees it: headers `.h` → `.hpp`; namespace `eprosima::fastrtps` →
// `eprosima::fastdds`; ReturnCode_t became an integer with free constants; DataWriter::write returns a
// ReturnCode_t; TopicDataType's virtual functions were renamed and take references; the discovery callbacks
// receive a status and the builtin topic data instead of a ParticipantDiscoveryInfo/ReaderDiscoveryInfo.
#pragma once

#ifndef XF_FASTDDS_MAJOR
#error "build.rs defines XF_FASTDDS_MAJOR (2 or 3)"
#endif

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/domain/DomainParticipantListener.hpp>
#include <fastdds/dds/domain/qos/DomainParticipantQos.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/DataWriterListener.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/Topic.hpp>
#include <fastdds/dds/topic/TopicDataType.hpp>

#if XF_FASTDDS_MAJOR >= 3
#include <fastdds/rtps/common/WriteParams.hpp>
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.hpp>
#include <fastdds/rtps/transport/shared_mem/SharedMemTransportDescriptor.hpp>
#include <fastdds/utils/IPLocator.hpp>
#else
#include <fastdds/rtps/common/WriteParams.h>
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastdds/rtps/transport/shared_mem/SharedMemTransportDescriptor.h>
#include <fastrtps/utils/IPLocator.h>
#endif

#include <cstdint>
#include <functional>
#include <string>

namespace xf {

using namespace eprosima::fastdds::dds;
// Transport descriptors were in eprosima::fastdds::rtps already in 2.x.
namespace transport = eprosima::fastdds::rtps;
#if XF_FASTDDS_MAJOR >= 3
namespace rtps = eprosima::fastdds::rtps;
using Duration = eprosima::fastdds::dds::Duration_t;
inline bool ok(ReturnCode_t rc) { return rc == RETCODE_OK; }
inline bool no_data(ReturnCode_t rc) { return rc == RETCODE_NO_DATA; }
#else
namespace rtps = eprosima::fastrtps::rtps;
using Duration = eprosima::fastrtps::Duration_t;
inline bool ok(const ReturnCode_t& rc) { return rc == ReturnCode_t::RETCODE_OK; }
inline bool no_data(const ReturnCode_t& rc) { return rc == ReturnCode_t::RETCODE_NO_DATA; }
#endif
using rtps::GUID_t;
using rtps::GuidPrefix_t;
using rtps::InstanceHandle_t;
using rtps::SampleIdentity;
using rtps::SequenceNumber_t;
using rtps::SerializedPayload_t;
using rtps::WriteParams;

inline bool write(DataWriter* w, void* data, WriteParams& params) {
#if XF_FASTDDS_MAJOR >= 3
    return ok(w->write(data, params));
#else
    return w->write(data, params);
#endif
}

// A payload codec with a runtime type name, implemented by RawType (xfast.cpp) in version-neutral terms; this
// class adapts it to each version's TopicDataType.
class OpaqueType : public TopicDataType {
public:
    OpaqueType(const std::string& name, bool keyed, uint32_t size_hint) : keyed_(keyed) {
#if XF_FASTDDS_MAJOR >= 3
        set_name(name);
        max_serialized_type_size = size_hint;
        is_compute_key_provided = keyed;
#else
        setName(name.c_str());
        m_typeSize = size_hint;
        m_isGetKeyDefined = keyed;
#endif
    }
    virtual bool encode(const void* data, SerializedPayload_t& p) = 0;
    virtual bool decode(const SerializedPayload_t& p, void* data) = 0;
    virtual uint32_t encoded_size(const void* data) = 0;
    virtual void* new_data() = 0;
    virtual void free_data(void* data) = 0;
    // The agent cannot compute a key from opaque bytes: one constant instance, as the rustdds engine does.
    bool constant_key(InstanceHandle_t& h) const {
        if (!keyed_) return false;
        for (int i = 0; i < 16; ++i) h.value[i] = 0;  // operator[] also marks the handle as defined
        h.value[15] = 1;
        return true;
    }

#if XF_FASTDDS_MAJOR >= 3
    bool serialize(const void* const data, SerializedPayload_t& p, DataRepresentationId_t) override {
        return encode(data, p);
    }
    bool deserialize(SerializedPayload_t& p, void* data) override { return decode(p, data); }
    uint32_t calculate_serialized_size(const void* const data, DataRepresentationId_t) override {
        return encoded_size(data);
    }
    void* create_data() override { return new_data(); }
    void delete_data(void* data) override { free_data(data); }
    bool compute_key(SerializedPayload_t&, InstanceHandle_t& h, bool) override { return constant_key(h); }
    bool compute_key(const void* const, InstanceHandle_t& h, bool) override { return constant_key(h); }
#else
    bool serialize(void* data, SerializedPayload_t* p) override { return encode(data, *p); }
    bool deserialize(SerializedPayload_t* p, void* data) override { return decode(*p, data); }
    std::function<uint32_t()> getSerializedSizeProvider(void* data) override {
        return [this, data]() { return encoded_size(data); };
    }
    void* createData() override { return new_data(); }
    void deleteData(void* data) override { free_data(data); }
    bool getKey(void*, InstanceHandle_t* h, bool) override { return constant_key(*h); }
#endif

private:
    bool keyed_;
};

// What the discovery callbacks report, in version-neutral terms.
enum class Seen { added, changed, removed };
struct SeenReader {
    GUID_t guid;
    std::string topic;
    std::string type;
    bool reliable;
    bool transient_local;
};

// A DomainParticipantListener that hands discovery to three version-neutral functions.
class DiscoveryListener : public DomainParticipantListener {
public:
    virtual void participant(DomainParticipant* self, const GuidPrefix_t& prefix, Seen what) = 0;
    virtual void reader(const SeenReader& r, Seen what) = 0;
    virtual void writer(const GuidPrefix_t& prefix) = 0;

#if XF_FASTDDS_MAJOR >= 3
    void on_participant_discovery(DomainParticipant* self, rtps::ParticipantDiscoveryStatus s,
                                  const ParticipantBuiltinTopicData& info, bool&) override {
        using S = rtps::ParticipantDiscoveryStatus;
        participant(self, info.guid.guidPrefix,
                    s == S::DISCOVERED_PARTICIPANT ? Seen::added
                    : s == S::CHANGED_QOS_PARTICIPANT ? Seen::changed : Seen::removed);
    }
    void on_data_reader_discovery(DomainParticipant*, rtps::ReaderDiscoveryStatus s,
                                  const SubscriptionBuiltinTopicData& info, bool&) override {
        using S = rtps::ReaderDiscoveryStatus;
        reader(SeenReader{info.guid, info.topic_name.to_string(), info.type_name.to_string(),
                          info.reliability.kind == RELIABLE_RELIABILITY_QOS,
                          info.durability.kind != VOLATILE_DURABILITY_QOS},
               s == S::DISCOVERED_READER ? Seen::added : s == S::CHANGED_QOS_READER ? Seen::changed : Seen::removed);
    }
    void on_data_writer_discovery(DomainParticipant*, rtps::WriterDiscoveryStatus,
                                  const PublicationBuiltinTopicData& info, bool&) override {
        writer(info.guid.guidPrefix);
    }
#else
    void on_participant_discovery(DomainParticipant* self, rtps::ParticipantDiscoveryInfo&& info) override {
        using I = rtps::ParticipantDiscoveryInfo;
        participant(self, info.info.m_guid.guidPrefix,
                    info.status == I::DISCOVERED_PARTICIPANT ? Seen::added
                    : info.status == I::CHANGED_QOS_PARTICIPANT ? Seen::changed : Seen::removed);
    }
    void on_subscriber_discovery(DomainParticipant*, rtps::ReaderDiscoveryInfo&& info) override {
        using I = rtps::ReaderDiscoveryInfo;
        const auto& r = info.info;
        reader(SeenReader{r.guid(), r.topicName().to_string(), r.typeName().to_string(),
                          r.m_qos.m_reliability.kind == RELIABLE_RELIABILITY_QOS,
                          r.m_qos.m_durability.kind != VOLATILE_DURABILITY_QOS},
               info.status == I::DISCOVERED_READER ? Seen::added
               : info.status == I::CHANGED_QOS_READER ? Seen::changed : Seen::removed);
    }
    void on_publisher_discovery(DomainParticipant*, rtps::WriterDiscoveryInfo&& info) override {
        writer(info.info.guid().guidPrefix);
    }
#endif
};

// Reliable protocol timings (renamed to snake_case in 3.x).
inline void set_heartbeat_period(DataWriterQos& q, const Duration& d) {
#if XF_FASTDDS_MAJOR >= 3
    q.reliable_writer_qos().times.heartbeat_period = d;
#else
    q.reliable_writer_qos().times.heartbeatPeriod = d;
#endif
}
inline void set_initial_acknack_delay(DataReaderQos& q, const Duration& d) {
#if XF_FASTDDS_MAJOR >= 3
    q.reliable_reader_qos().times.initial_acknack_delay = d;
#else
    q.reliable_reader_qos().times.initialAcknackDelay = d;
#endif
}

inline GUID_t handle_to_guid(const InstanceHandle_t& h) { return rtps::iHandle2GUID(h); }

}  // namespace xf
