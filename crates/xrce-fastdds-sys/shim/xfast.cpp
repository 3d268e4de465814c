// C ABI over Fast DDS 2.9 (Debian libfastrtps-dev) for untyped pub/sub: runtime topic and type names, payloads
// are opaque CDR bodies. Every entry point catches C++ exceptions and reports failure through its return value,
// because unwinding into Rust is undefined behaviour.
#include <cstring>

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
#include <fastdds/rtps/common/WriteParams.h>
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>

#include <cstdint>
#include <cstring>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <vector>

using namespace eprosima::fastdds::dds;
using eprosima::fastrtps::Duration_t;
using eprosima::fastrtps::rtps::GUID_t;
using eprosima::fastrtps::rtps::InstanceHandle_t;
using eprosima::fastrtps::rtps::GuidPrefix_t;
using eprosima::fastrtps::rtps::ParticipantDiscoveryInfo;
using eprosima::fastrtps::rtps::ReaderDiscoveryInfo;
using eprosima::fastrtps::rtps::WriterDiscoveryInfo;
using eprosima::fastrtps::rtps::SampleIdentity;
using eprosima::fastrtps::rtps::SequenceNumber_t;
using eprosima::fastrtps::rtps::SerializedPayload_t;
using eprosima::fastrtps::rtps::WriteParams;

extern "C" {

// Plain structs shared with Rust (src/ffi.rs mirrors them field by field).
struct xf_guid { uint8_t v[16]; };
struct xf_sample_identity { xf_guid writer; int64_t sn; };  // sn < 0: unknown
struct xf_qos {
    uint8_t reliable;
    uint8_t transient_local;
    uint8_t keep_all;
    uint8_t _pad;
    int32_t depth;                     // keep-last depth (>= 1)
    int32_t max_samples;               // resource limits; <= 0: unlimited
    int32_t max_instances;
    int32_t max_samples_per_instance;
    uint32_t max_blocking_ms;          // how long a reliable write may wait for room in the history
    uint32_t heartbeat_ms;             // reliable writer heartbeat period
    uint32_t acknack_delay_ms;         // reliable reader delay before its first ACKNACK
};
struct xf_participant_cfg {
    uint32_t domain;
    const char* name;
    const char* const* whitelist;      // interface addresses; empty: every interface
    size_t n_whitelist;
    uint32_t announcements;            // initial SPDP announcements
    uint32_t announcement_period_ms;
};
struct xf_take_info {
    xf_sample_identity sample_identity;
    xf_sample_identity related_sample_identity;
    const uint8_t* body;               // body without the 4-byte encapsulation header; valid until next take
    size_t len;
    uint16_t encapsulation;            // representation id (0x0001 CDR_LE, ...)
    uint8_t valid_data;
    uint8_t _pad;
};
typedef void (*xf_cb)(void* ctx);
}

namespace {

// What Fast DDS hands to serialize/deserialize. On write the body is borrowed from the caller (no copy before
// serialization); on take it is owned.
struct RawData {
    const uint8_t* out = nullptr;
    size_t out_len = 0;
    std::vector<uint8_t> in;
    uint16_t encapsulation = 0x0001;
};

// Opaque type with a runtime name: payload = encapsulation header + body as given.
class RawType : public TopicDataType {
public:
    RawType(const std::string& name, bool keyed) {
        setName(name.c_str());
        m_typeSize = 4 + 64;  // a hint only: endpoints use dynamic payload memory
        m_isGetKeyDefined = keyed;
    }
    bool serialize(void* data, SerializedPayload_t* p) override {
        auto* d = static_cast<RawData*>(data);
        size_t need = 4 + d->out_len;
        if (p->max_size < need) return false;
        p->data[0] = static_cast<uint8_t>(d->encapsulation >> 8);
        p->data[1] = static_cast<uint8_t>(d->encapsulation & 0xff);
        p->data[2] = 0;
        p->data[3] = 0;
        if (d->out_len) std::memcpy(p->data + 4, d->out, d->out_len);
        p->length = static_cast<uint32_t>(need);
        p->encapsulation = (d->encapsulation & 1) ? CDR_LE : CDR_BE;
        return true;
    }
    bool deserialize(SerializedPayload_t* p, void* data) override {
        auto* d = static_cast<RawData*>(data);
        if (p->length < 4) return false;
        d->encapsulation = static_cast<uint16_t>((p->data[0] << 8) | p->data[1]);
        d->in.assign(p->data + 4, p->data + p->length);
        return true;
    }
    std::function<uint32_t()> getSerializedSizeProvider(void* data) override {
        auto* d = static_cast<RawData*>(data);
        return [d]() { return static_cast<uint32_t>(4 + d->out_len); };
    }
    void* createData() override { return new RawData(); }
    void deleteData(void* data) override { delete static_cast<RawData*>(data); }
    bool getKey(void*, InstanceHandle_t* h, bool) override {
        // The agent cannot compute a key from opaque bytes: one constant instance, as the rustdds engine does.
        if (!m_isGetKeyDefined) return false;
        for (int i = 0; i < 16; ++i) h->value[i] = 0;  // operator[] also marks the handle as defined
        h->value[15] = 1;
        return true;
    }
};

void put_guid(const GUID_t& g, xf_guid* out) {
    std::memcpy(out->v, g.guidPrefix.value, 12);
    std::memcpy(out->v + 12, g.entityId.value, 4);
}
GUID_t get_guid(const xf_guid& in) {
    GUID_t g;
    std::memcpy(g.guidPrefix.value, in.v, 12);
    std::memcpy(g.entityId.value, in.v + 12, 4);
    return g;
}
void put_si(const SampleIdentity& s, xf_sample_identity* out) {
    put_guid(s.writer_guid(), &out->writer);
    const auto& sn = s.sequence_number();
    out->sn = (sn == SequenceNumber_t::unknown()) ? -1 : static_cast<int64_t>(sn.to64long());
}
Duration_t ms(uint32_t v) { return Duration_t(static_cast<int32_t>(v / 1000), (v % 1000) * 1000000u); }

// The callback runs under `m`, so clearing it (before deletion) waits for a callback in progress: after
// xf_reader_delete returns, Rust may free the context.
struct CbListener : public DataReaderListener {
    std::mutex m;
    xf_cb cb = nullptr;
    void* ctx = nullptr;
    void on_data_available(DataReader*) override {
        std::lock_guard<std::mutex> g(m);
        if (cb) cb(ctx);
    }
};

// What a participant has discovered, for the agent's first-contact gate (see xf_writer_unmatched_known): the
// remote readers, which a writer of another participant of the agent may not have matched yet, and the remote
// participants whose endpoints have not arrived yet (their discovery, SEDP, still under way).
struct KnownReader {
    std::string topic;
    std::string type;
    bool reliable;
    bool transient_local;
};
struct Discovery : public DomainParticipantListener {
    std::mutex m;
    std::map<GUID_t, KnownReader> readers;
    std::set<GuidPrefix_t> awaiting_endpoints;
    std::set<GuidPrefix_t> participants;  // remote ones alive, of other processes
    std::set<GuidPrefix_t> discovered;    // every one alive, the agent's other participants included
    void on_participant_discovery(DomainParticipant* self, ParticipantDiscoveryInfo&& info) override {
        std::lock_guard<std::mutex> g(m);
        const GuidPrefix_t& p = info.info.m_guid.guidPrefix;
        if (info.status == ParticipantDiscoveryInfo::DISCOVERED_PARTICIPANT) {
            discovered.insert(p);
            // The agent's other participants (same host and process bytes of the prefix) are not awaited.
            const bool same_process = std::memcmp(p.value, self->guid().guidPrefix.value, 8) == 0;
            if (!same_process) {
                awaiting_endpoints.insert(p);
                participants.insert(p);
            }
        } else if (info.status != ParticipantDiscoveryInfo::CHANGED_QOS_PARTICIPANT) {
            awaiting_endpoints.erase(p);
            participants.erase(p);
            discovered.erase(p);
        }
    }
    void on_publisher_discovery(DomainParticipant*, WriterDiscoveryInfo&& info) override {
        std::lock_guard<std::mutex> g(m);
        awaiting_endpoints.erase(info.info.guid().guidPrefix);
    }
    void on_subscriber_discovery(DomainParticipant*, ReaderDiscoveryInfo&& info) override {
        std::lock_guard<std::mutex> g(m);
        const auto& r = info.info;
        awaiting_endpoints.erase(r.guid().guidPrefix);
        switch (info.status) {
            case ReaderDiscoveryInfo::DISCOVERED_READER:
            case ReaderDiscoveryInfo::CHANGED_QOS_READER:
                readers[r.guid()] = KnownReader{r.topicName().to_string(), r.typeName().to_string(),
                                                r.m_qos.m_reliability.kind == RELIABLE_RELIABILITY_QOS,
                                                r.m_qos.m_durability.kind != VOLATILE_DURABILITY_QOS};
                break;
            default:
                readers.erase(r.guid());
        }
    }
};

// The readers a writer has matched (Fast DDS 2.9 does not implement get_matched_subscriptions).
struct MatchListener : public DataWriterListener {
    std::mutex m;
    std::set<GUID_t> matched;
    void on_publication_matched(DataWriter*, const PublicationMatchedStatus& s) override {
        GUID_t g = eprosima::fastrtps::rtps::iHandle2GUID(s.last_subscription_handle);
        std::lock_guard<std::mutex> l(m);
        if (s.current_count_change > 0) matched.insert(g);
        if (s.current_count_change < 0) matched.erase(g);
    }
};

template <class Q> void apply_common(Q& q, const xf_qos& x) {
    q.reliability().kind = x.reliable ? RELIABLE_RELIABILITY_QOS : BEST_EFFORT_RELIABILITY_QOS;
    q.reliability().max_blocking_time = ms(x.max_blocking_ms);
    q.durability().kind = x.transient_local ? TRANSIENT_LOCAL_DURABILITY_QOS : VOLATILE_DURABILITY_QOS;
    q.history().kind = x.keep_all ? KEEP_ALL_HISTORY_QOS : KEEP_LAST_HISTORY_QOS;
    q.history().depth = x.depth > 0 ? x.depth : 1;
    q.resource_limits().max_samples = x.max_samples > 0 ? x.max_samples : -1;
    q.resource_limits().max_instances = x.max_instances > 0 ? x.max_instances : -1;
    q.resource_limits().max_samples_per_instance = x.max_samples_per_instance > 0 ? x.max_samples_per_instance : -1;
    // Preallocating the whole history would cost max_samples payloads per endpoint at creation.
    q.resource_limits().allocated_samples = x.max_samples > 0 ? std::min(x.max_samples, 64) : 64;
    q.endpoint().history_memory_policy = eprosima::fastrtps::rtps::DYNAMIC_REUSABLE_MEMORY_MODE;
    // Data sharing maps segments in /dev/shm, which Fast DDS 2.14 peers lay out differently.
    q.data_sharing().off();
}

}  // namespace

struct xf_participant { DomainParticipant* p; Discovery discovery; uint32_t reannounced = 0; };

namespace {
// The process's participants, for xf_participant_reannounce_unheard. A participant leaves it before deletion.
std::mutex registry_m;
std::set<xf_participant*> registry;
}  // namespace
struct xf_writer { DataWriter* w; Publisher* pub; MatchListener listener; xf_participant* owner; };
struct xf_reader { DataReader* r; Subscriber* sub; CbListener listener; RawData scratch; };

#define XF_TRY try {
#define XF_CATCH(ret) } catch (...) { return ret; }

extern "C" {

int xf_available() { return 1; }

xf_participant* xf_participant_new(const xf_participant_cfg* c) {
    XF_TRY
    DomainParticipantQos q = PARTICIPANT_QOS_DEFAULT;
    q.name(c->name ? c->name : "xrce-rs");
    // UDPv4 only: the SHM transport's segments are incompatible between Fast DDS 2.9 and 2.14.
    q.transport().use_builtin_transports = false;
    auto udp = std::make_shared<eprosima::fastdds::rtps::UDPv4TransportDescriptor>();
    for (size_t i = 0; i < c->n_whitelist; ++i) udp->interfaceWhiteList.emplace_back(c->whitelist[i]);
    q.transport().user_transports.push_back(udp);
    auto& ann = q.wire_protocol().builtin.discovery_config.initial_announcements;
    ann.count = c->announcements;
    ann.period = ms(c->announcement_period_ms);
    // The listener lives in the handle, so the handle exists first; discovery callbacks need no status mask.
    auto* h = new xf_participant{nullptr, {}};
    h->p = DomainParticipantFactory::get_instance()->create_participant(c->domain, q, &h->discovery,
                                                                       StatusMask::none());
    if (!h->p) { delete h; return nullptr; }
    {
        std::lock_guard<std::mutex> g(registry_m);
        registry.insert(h);
    }
    return h;
    XF_CATCH(nullptr)
}

void xf_participant_delete(xf_participant* p) {
    if (!p) return;
    try {
        {
            std::lock_guard<std::mutex> g(registry_m);
            registry.erase(p);
        }
        p->p->delete_contained_entities();
        DomainParticipantFactory::get_instance()->delete_participant(p->p);
    } catch (...) {}
    delete p;
}

void xf_participant_guid(const xf_participant* p, xf_guid* out) { put_guid(p->p->guid(), out); }

// Registers the opaque type once per participant and name; 0 on success.
int xf_register_type(xf_participant* p, const char* type_name, uint8_t keyed) {
    XF_TRY
    if (p->p->find_type(type_name).get() != nullptr) return 0;
    TypeSupport ts(new RawType(type_name, keyed != 0));
    return p->p->register_type(ts) == ReturnCode_t::RETCODE_OK ? 0 : -1;
    XF_CATCH(-2)
}

Topic* xf_topic_new(xf_participant* p, const char* name, const char* type_name) {
    XF_TRY
    return p->p->create_topic(name, type_name, TOPIC_QOS_DEFAULT);
    XF_CATCH(nullptr)
}

void xf_topic_delete(xf_participant* p, Topic* t) {
    try { p->p->delete_topic(t); } catch (...) {}
}

xf_writer* xf_writer_new(xf_participant* p, Topic* t, const xf_qos* qos, const char* const* parts, size_t n_parts) {
    XF_TRY
    PublisherQos pq = PUBLISHER_QOS_DEFAULT;
    for (size_t i = 0; i < n_parts; ++i) pq.partition().push_back(parts[i]);
    Publisher* pub = p->p->create_publisher(pq);
    if (!pub) return nullptr;
    DataWriterQos q = DATAWRITER_QOS_DEFAULT;
    apply_common(q, *qos);
    q.reliable_writer_qos().times.heartbeatPeriod = ms(qos->heartbeat_ms);
    auto* w = new xf_writer{nullptr, pub, {}, p};
    w->w = pub->create_datawriter(t, q, &w->listener, StatusMask::publication_matched());
    if (!w->w) { p->p->delete_publisher(pub); delete w; return nullptr; }
    return w;
    XF_CATCH(nullptr)
}

void xf_writer_delete(xf_participant* p, xf_writer* w) {
    if (!w) return;
    try { w->pub->delete_datawriter(w->w); p->p->delete_publisher(w->pub); } catch (...) {}
    delete w;
}

void xf_writer_guid(const xf_writer* w, xf_guid* out) { put_guid(w->w->guid(), out); }

int32_t xf_writer_matched(xf_writer* w) {
    XF_TRY
    PublicationMatchedStatus s;
    if (w->w->get_publication_matched_status(s) != ReturnCode_t::RETCODE_OK) return -1;
    return s.current_count;
    XF_CATCH(-2)
}

// Whether the writer has matched a reader of the participant whose GUID prefix is `prefix` (12 bytes): 1 yes,
// 0 no, < 0 error. A reply is held until its requester's reply reader is matched (a volatile reader matched
// later would never get it).
int32_t xf_writer_matched_prefix(xf_writer* w, const uint8_t* prefix) {
    XF_TRY
    std::lock_guard<std::mutex> g(w->listener.m);
    for (const GUID_t& guid : w->listener.matched) {
        if (std::memcmp(guid.guidPrefix.value, prefix, 12) == 0) return 1;
    }
    return 0;
    XF_CATCH(-2)
}

// Readers `oracle` has discovered on the writer's topic and type, with a QoS the writer can serve, that the
// writer has not matched yet. `oracle` may be the writer's own participant or another of the process (one that
// has been running longer knows more). May throw (callers catch).
}  // extern "C"
namespace {
std::vector<GUID_t> unmatched_known_readers(xf_writer* w, xf_participant* oracle) {
    std::set<GUID_t> matched;
    {
        std::lock_guard<std::mutex> g(w->listener.m);
        matched = w->listener.matched;
    }
    const std::string topic = w->w->get_topic()->get_name();
    const std::string type = w->w->get_topic()->get_type_name();
    const DataWriterQos q = w->w->get_qos();
    const bool reliable = q.reliability().kind == RELIABLE_RELIABILITY_QOS;
    const bool transient_local = q.durability().kind != VOLATILE_DURABILITY_QOS;
    const auto own = w->w->guid().guidPrefix;
    std::vector<GUID_t> unmatched;
    std::lock_guard<std::mutex> g(oracle->discovery.m);
    for (const auto& kv : oracle->discovery.readers) {
        const GUID_t& guid = kv.first;
        const KnownReader& r = kv.second;
        if (r.topic != topic || r.type != type) continue;
        if ((r.reliable && !reliable) || (r.transient_local && !transient_local)) continue;
        if (guid.guidPrefix == own || matched.count(guid) != 0) continue;
        unmatched.push_back(guid);
    }
    return unmatched;
}
}  // namespace
extern "C" {

// How many readers unmatched_known_readers finds (< 0: error).
int32_t xf_writer_unmatched_known(xf_writer* w, xf_participant* oracle) {
    XF_TRY
    return static_cast<int32_t>(unmatched_known_readers(w, oracle).size());
    XF_CATCH(-2)
}

// Of the readers unmatched_known_readers finds, those whose participant the writer's own participant has not
// discovered yet or has no endpoint of yet: discovery with them is under way, so the writer may still match
// them (a reader whose participant's endpoints did arrive and that is still unmatched will not match).
int32_t xf_writer_unmatched_in_discovery(xf_writer* w, xf_participant* oracle) {
    XF_TRY
    const std::vector<GUID_t> unmatched = unmatched_known_readers(w, oracle);
    xf_participant* mine = w->owner;
    std::lock_guard<std::mutex> g(mine->discovery.m);
    int32_t n = 0;
    for (const auto& guid : unmatched) {
        const auto& prefix = guid.guidPrefix;
        if (mine->discovery.discovered.count(prefix) == 0 || mine->discovery.awaiting_endpoints.count(prefix) != 0) ++n;
    }
    return n;
    XF_CATCH(-2)
}

// Remote participants whose discovery with `p` is still under way, so that `p` may be about to learn of
// readers a new writer should not miss: those `p` has discovered but has no endpoint of yet, and those
// `oracle` (a participant that has run longer) knows and `p` has not discovered yet.
int32_t xf_participant_in_discovery(xf_participant* p, xf_participant* oracle) {
    XF_TRY
    std::set<GuidPrefix_t> known;
    if (oracle != p) {
        std::lock_guard<std::mutex> g(oracle->discovery.m);
        known = oracle->discovery.participants;
    }
    std::lock_guard<std::mutex> g(p->discovery.m);
    int32_t n = static_cast<int32_t>(p->discovery.awaiting_endpoints.size());
    for (const auto& prefix : known) {
        if (p->discovery.participants.count(prefix) == 0) ++n;
    }
    return n;
    XF_CATCH(-2)
}

// Participants `oracle` has discovered (the agent's own included) and `oracle` itself that `p` has not
// discovered: each answered p's first announcement once, and Fast DDS drops what arrives before p's receivers
// are registered, which happens after that announcement (RTPSParticipantImpl::enable). Such a participant
// stays unknown to p until its next periodic announcement (3 s by default).
int32_t xf_participant_undiscovered(xf_participant* p, xf_participant* oracle) {
    XF_TRY
    if (oracle == p) return 0;
    std::set<GuidPrefix_t> wanted;
    {
        std::lock_guard<std::mutex> g(oracle->discovery.m);
        wanted = oracle->discovery.discovered;
    }
    wanted.insert(oracle->p->guid().guidPrefix);
    wanted.erase(p->p->guid().guidPrefix);
    // This process's participants count only while they live: one just deleted (a participant created again
    // by the agent) may still be in the oracle's table, and will never be discovered.
    std::set<GuidPrefix_t> alive;
    {
        std::lock_guard<std::mutex> g(registry_m);
        for (xf_participant* x : registry) alive.insert(x->p->guid().guidPrefix);
    }
    const auto& own = p->p->guid().guidPrefix;
    std::lock_guard<std::mutex> g(p->discovery.m);
    int32_t n = 0;
    for (const auto& prefix : wanted) {
        const bool same_process = std::memcmp(prefix.value, own.value, 8) == 0;
        if (same_process && alive.count(prefix) == 0) continue;
        if (p->discovery.discovered.count(prefix) == 0) ++n;
    }
    return n;
    XF_CATCH(-2)
}

// Makes every other participant of this process in p's domain that p has not discovered announce itself again,
// by changing its USER_DATA (Fast DDS sends a participant's DATA(p) to every peer when it changes): their
// answers to p's first announcement may have been dropped (see xf_participant_undiscovered). USER_DATA then
// reads "xrce-rs-announce=N;", which ROS 2 ignores (it reads only "enclave="). How many were asked (< 0: error).
int32_t xf_participant_reannounce_unheard(xf_participant* p) {
    XF_TRY
    std::set<GuidPrefix_t> heard;
    {
        std::lock_guard<std::mutex> g(p->discovery.m);
        heard = p->discovery.discovered;
    }
    const auto domain = p->p->get_domain_id();
    int32_t n = 0;
    std::lock_guard<std::mutex> g(registry_m);
    for (xf_participant* x : registry) {
        if (x == p || x->p->get_domain_id() != domain || heard.count(x->p->guid().guidPrefix) != 0) continue;
        DomainParticipantQos q = x->p->get_qos();
        const std::string tag = "xrce-rs-announce=" + std::to_string(++x->reannounced) + ";";
        q.user_data().data_vec(std::vector<eprosima::fastrtps::rtps::octet>(tag.begin(), tag.end()));
        if (x->p->set_qos(q) == ReturnCode_t::RETCODE_OK) ++n;
    }
    return n;
    XF_CATCH(-2)
}

// Writes `body` (CDR without header, little endian). Thread-safe: the sample lives on this stack frame.
// Returns 0, -1 when Fast DDS refused (history full after max_blocking_time), -2 on exception.
int xf_write(xf_writer* w, const uint8_t* body, size_t len, const xf_sample_identity* related,
             xf_sample_identity* written) {
    XF_TRY
    RawData d;
    d.out = body;
    d.out_len = len;
    WriteParams wp;
    if (related) {
        wp.related_sample_identity().writer_guid(get_guid(related->writer));
        if (related->sn >= 0) {
            SequenceNumber_t sn(static_cast<int32_t>(related->sn >> 32), static_cast<uint32_t>(related->sn & 0xffffffff));
            wp.related_sample_identity().sequence_number(sn);
        }
    }
    if (!w->w->write(&d, wp)) return -1;
    if (written) put_si(wp.sample_identity(), written);
    return 0;
    XF_CATCH(-2)
}

int xf_writer_wait_acked(xf_writer* w, uint32_t wait_ms) {
    XF_TRY
    return w->w->wait_for_acknowledgments(ms(wait_ms)) == ReturnCode_t::RETCODE_OK ? 0 : -1;
    XF_CATCH(-2)
}

// The listener (and its callback) is installed at creation, so no sample can arrive unnoticed.
xf_reader* xf_reader_new(xf_participant* p, Topic* t, const xf_qos* qos, const char* const* parts, size_t n_parts,
                         xf_cb cb, void* ctx) {
    XF_TRY
    SubscriberQos sq = SUBSCRIBER_QOS_DEFAULT;
    for (size_t i = 0; i < n_parts; ++i) sq.partition().push_back(parts[i]);
    Subscriber* sub = p->p->create_subscriber(sq);
    if (!sub) return nullptr;
    DataReaderQos q = DATAREADER_QOS_DEFAULT;
    apply_common(q, *qos);
    q.reliable_reader_qos().times.initialAcknackDelay = ms(qos->acknack_delay_ms);
    auto* r = new xf_reader{nullptr, sub, {}, {}};
    r->listener.cb = cb;
    r->listener.ctx = ctx;
    r->r = sub->create_datareader(t, q, &r->listener, StatusMask::data_available());
    if (!r->r) { p->p->delete_subscriber(sub); delete r; return nullptr; }
    return r;
    XF_CATCH(nullptr)
}

void xf_reader_delete(xf_participant* p, xf_reader* r) {
    if (!r) return;
    {
        std::lock_guard<std::mutex> g(r->listener.m);
        r->listener.cb = nullptr;
    }
    try { r->sub->delete_datareader(r->r); p->p->delete_subscriber(r->sub); } catch (...) {}
    delete r;
}

void xf_reader_guid(const xf_reader* r, xf_guid* out) { put_guid(r->r->guid(), out); }

int32_t xf_reader_matched(xf_reader* r) {
    XF_TRY
    SubscriptionMatchedStatus s;
    if (r->r->get_subscription_matched_status(s) != ReturnCode_t::RETCODE_OK) return -1;
    return s.current_count;
    XF_CATCH(-2)
}

// Takes one sample: 1 taken (info filled, info->body points into the reader's scratch until the next take),
// 0 none, < 0 error. Not thread-safe per reader (the Rust side serializes takes).
int xf_take(xf_reader* r, xf_take_info* info) {
    XF_TRY
    SampleInfo si;
    ReturnCode_t rc = r->r->take_next_sample(&r->scratch, &si);
    if (rc == ReturnCode_t::RETCODE_NO_DATA) return 0;
    if (rc != ReturnCode_t::RETCODE_OK) return -1;
    put_si(si.sample_identity, &info->sample_identity);
    put_si(si.related_sample_identity, &info->related_sample_identity);
    info->valid_data = si.valid_data ? 1 : 0;
    info->encapsulation = r->scratch.encapsulation;
    info->body = r->scratch.in.data();
    info->len = si.valid_data ? r->scratch.in.size() : 0;
    return 1;
    XF_CATCH(-2)
}

}  // extern "C"
