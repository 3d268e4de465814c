// C ABI over Fast DDS 2.x and 3.x for untyped pub/sub: runtime topic and type names, payloads are opaque CDR
// bodies. What differs between the versions is in compat.hpp. Every entry point catches C++ exceptions and
// reports failure through its return value, because unwinding into Rust is undefined behaviour.
#include "compat.hpp"

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <cstring>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

using namespace xf;

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
    uint8_t shared_memory;             // 1: shared memory and UDPv4; 0: UDPv4 only
    uint8_t range;                     // XF_RANGE_*: ROS_AUTOMATIC_DISCOVERY_RANGE as rmw_fastrtps applies it
    uint8_t _pad[2];
    const char* const* peers;          // initial peers (IPv4 addresses), added to the profile's
    size_t n_peers;
};
// Discovery ranges (the Rust side resolves SUBNET's and SYSTEM_DEFAULT's difference: the peers it passes).
enum { XF_RANGE_DEFAULT = 0, XF_RANGE_LOCALHOST = 1, XF_RANGE_OFF = 2 };
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
class RawType : public OpaqueType {
public:
    // The size is a hint only: endpoints use dynamic payload memory.
    RawType(const std::string& name, bool keyed) : OpaqueType(name, keyed, 4 + 64) {}
    bool encode(const void* data, SerializedPayload_t& p) override {
        const auto* d = static_cast<const RawData*>(data);
        size_t need = 4 + d->out_len;
        if (p.max_size < need) return false;
        p.data[0] = static_cast<uint8_t>(d->encapsulation >> 8);
        p.data[1] = static_cast<uint8_t>(d->encapsulation & 0xff);
        p.data[2] = 0;
        p.data[3] = 0;
        if (d->out_len) std::memcpy(p.data + 4, d->out, d->out_len);
        p.length = static_cast<uint32_t>(need);
        p.encapsulation = (d->encapsulation & 1) ? CDR_LE : CDR_BE;
        return true;
    }
    bool decode(const SerializedPayload_t& p, void* data) override {
        auto* d = static_cast<RawData*>(data);
        if (p.length < 4) return false;
        d->encapsulation = static_cast<uint16_t>((p.data[0] << 8) | p.data[1]);
        d->in.assign(p.data + 4, p.data + p.length);
        return true;
    }
    uint32_t encoded_size(const void* data) override {
        return static_cast<uint32_t>(4 + static_cast<const RawData*>(data)->out_len);
    }
    void* new_data() override { return new RawData(); }
    void free_data(void* data) override { delete static_cast<RawData*>(data); }
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
Duration ms(uint32_t v) { return Duration(static_cast<int32_t>(v / 1000), (v % 1000) * 1000000u); }

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
// A remote participant's endpoints arrive in bursts (SEDP), the one a writer waits for possibly last, and a ROS
// node that has just started keeps announcing endpoints: with `settle_ms` > 0 its discovery counts as under way
// until none has arrived for that long (the agent passes 100 ms for reliable writers: on loopback a burst's
// endpoints come within a few ms of each other); with 0, only until its first endpoint arrived.

// A remote participant that has just started drops what reaches it before its receivers are registered (Fast
// DDS: RTPSParticipantImpl::enable), our participant's answer to its first announcement included; it then
// learns of us, and sends us its endpoints, only at our next periodic announcement, 3 s later (a ROS node
// started next to a running agent: its reader unknown to the first-contact gate, its first service call 3 s
// late). So a remote participant discovered without any endpoint of its own `kAnswerCheck` later gets our
// announcement again (the answerer thread, answer_again_if_unheard), and once more `kAnswerRecheck` after that.
constexpr auto kAnswerCheck = std::chrono::milliseconds(60);
constexpr auto kAnswerRecheck = std::chrono::milliseconds(400);
void answerer_wake();

struct Discovery : public DiscoveryListener {
    using Clock = std::chrono::steady_clock;
    std::mutex m;
    std::map<GUID_t, KnownReader> readers;
    std::set<GuidPrefix_t> awaiting_endpoints;        // no endpoint of theirs yet
    std::map<GuidPrefix_t, Clock::time_point> latest;  // when their latest endpoint (or themselves) arrived
    std::set<GuidPrefix_t> participants;  // remote ones alive, of other processes
    std::set<GuidPrefix_t> discovered;    // every one alive, the agent's other participants included
    // Remote participants without any endpoint yet, and when to announce ourselves to them again (see
    // answer_again_if_unheard): the second check, once the first announcement again went unanswered too.
    std::map<GuidPrefix_t, std::pair<Clock::time_point, bool>> unanswered;
    void participant(DomainParticipant* self, const GuidPrefix_t& p, Seen what) override {
        bool wake = false;
        {
            std::lock_guard<std::mutex> g(m);
            if (what == Seen::added) {
                discovered.insert(p);
                // The agent's other participants (same host and process bytes of the prefix) are not awaited.
                const bool same_process = std::memcmp(p.value, self->guid().guidPrefix.value, 8) == 0;
                if (!same_process) {
                    awaiting_endpoints.insert(p);
                    participants.insert(p);
                    latest[p] = Clock::now();
                    unanswered[p] = {Clock::now() + kAnswerCheck, false};
                    wake = true;
                }
            } else if (what == Seen::removed) {
                awaiting_endpoints.erase(p);
                participants.erase(p);
                discovered.erase(p);
                latest.erase(p);
                unanswered.erase(p);
            }
        }
        if (wake) answerer_wake();
    }
    void endpoint_of(const GuidPrefix_t& p) {
        awaiting_endpoints.erase(p);
        unanswered.erase(p);
        auto it = latest.find(p);
        if (it != latest.end()) it->second = Clock::now();
    }
    // Remote participants whose endpoints are still arriving (none yet, or one within `settle_ms`). Called
    // with `m` held.
    std::set<GuidPrefix_t> unsettled(uint32_t settle_ms) const {
        std::set<GuidPrefix_t> out(awaiting_endpoints);
        const auto now = Clock::now();
        const auto settle = std::chrono::milliseconds(settle_ms);
        for (const auto& kv : latest) {
            if (now - kv.second < settle) out.insert(kv.first);
        }
        return out;
    }
    void writer(const GuidPrefix_t& p) override {
        std::lock_guard<std::mutex> g(m);
        endpoint_of(p);
    }
    void reader(const SeenReader& r, Seen what) override {
        std::lock_guard<std::mutex> g(m);
        endpoint_of(r.guid.guidPrefix);
        if (what == Seen::removed) {
            readers.erase(r.guid);
        } else {
            readers[r.guid] = KnownReader{r.topic, r.type, r.reliable, r.transient_local};
        }
    }
};

// The readers a writer has matched (Fast DDS 2.9 does not implement get_matched_subscriptions).
struct MatchListener : public DataWriterListener {
    std::mutex m;
    std::set<GUID_t> matched;
    void on_publication_matched(DataWriter*, const PublicationMatchedStatus& s) override {
        GUID_t g = handle_to_guid(s.last_subscription_handle);
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
    q.endpoint().history_memory_policy = rtps::DYNAMIC_REUSABLE_MEMORY_MODE;
    // Data sharing needs bounded types; these are opaque and unbounded.
    q.data_sharing().off();
}

}  // namespace

struct xf_participant { DomainParticipant* p; Discovery discovery; uint32_t reannounced = 0; };

namespace {
// The process's participants, for xf_participant_reannounce_unheard. A participant leaves it before deletion.
// Both outlive static destruction (never freed): the answerer thread may use them while the process exits.
std::mutex& registry_m = *new std::mutex();
std::set<xf_participant*>& registry = *new std::set<xf_participant*>();

// Makes `x` announce itself to every peer by changing its USER_DATA (Fast DDS sends a participant's DATA(p) to
// every peer when it changes). USER_DATA then reads "xrce-rs-announce=N;", which ROS 2 ignores (it reads only
// "enclave="). Whether Fast DDS took the change.
bool announce_again(xf_participant* x) {
    DomainParticipantQos q = x->p->get_qos();
    const std::string tag = "xrce-rs-announce=" + std::to_string(++x->reannounced) + ";";
    q.user_data().data_vec(std::vector<rtps::octet>(tag.begin(), tag.end()));
    return ok(x->p->set_qos(q));
}

// The answerer: a thread, started with the first participant, that sleeps until a remote participant has been
// discovered and then, while any is still unanswered (see kAnswerCheck), looks every 20 ms.
struct Answerer {
    std::mutex m;
    std::condition_variable cv;
    uint64_t wakes = 0;
};
Answerer& answerer = *new Answerer();

// Announces each participant of the process again whose unanswered peers are due; whether any is left.
bool answer_again_if_unheard() {
    bool left = false;
    std::lock_guard<std::mutex> g(registry_m);
    for (xf_participant* x : registry) {
        bool due = false;
        {
            std::lock_guard<std::mutex> d(x->discovery.m);
            const auto now = Discovery::Clock::now();
            auto& pending = x->discovery.unanswered;
            for (auto it = pending.begin(); it != pending.end();) {
                if (now < it->second.first) {
                    ++it;
                    continue;
                }
                due = true;
                if (it->second.second) {
                    it = pending.erase(it);
                } else {
                    it->second = {now + kAnswerRecheck, true};
                    ++it;
                }
            }
            left = left || !pending.empty();
        }
        if (due) {
            try { announce_again(x); } catch (...) {}
        }
    }
    return left;
}

void answerer_run() {
    for (;;) {
        uint64_t seen;
        {
            std::unique_lock<std::mutex> lk(answerer.m);
            answerer.cv.wait(lk, [] { return answerer.wakes != 0; });
            seen = answerer.wakes;
        }
        bool left = true;
        while (left) {
            std::this_thread::sleep_for(std::chrono::milliseconds(20));
            left = answer_again_if_unheard();
        }
        // Sleep again unless a participant was discovered since the last look.
        std::lock_guard<std::mutex> lk(answerer.m);
        if (answerer.wakes == seen) answerer.wakes = 0;
    }
}

void answerer_start() {
    static std::once_flag started;
    std::call_once(started, [] { std::thread(answerer_run).detach(); });
}
}  // namespace

namespace {
void answerer_wake() {
    {
        std::lock_guard<std::mutex> lk(answerer.m);
        ++answerer.wakes;
    }
    answerer.cv.notify_one();
}
}  // namespace
struct xf_writer { DataWriter* w; Publisher* pub; MatchListener listener; xf_participant* owner; };
struct xf_reader { DataReader* r; Subscriber* sub; CbListener listener; RawData scratch; };

#define XF_TRY try {
#define XF_CATCH(ret) } catch (...) { return ret; }

extern "C" {

int xf_available() { return 1; }

// Loads the user's Fast DDS profiles as an rmw_fastrtps node does before its participant: the file its
// version's variable names (FASTRTPS_DEFAULT_PROFILES_FILE in 2.x, FASTDDS_DEFAULT_PROFILES_FILE in 3.x) and
// the default file of the working directory. Their default participant and endpoint profiles are the base of
// every participant of the agent. `file` (absolute, or null) is that variable's file, loaded first because
// load_profiles() reports no parse error (Fast DDS keeps it as loaded, so it is not parsed twice). 0, or -1
// when `file` does not parse (Fast DDS has logged why).
int xf_load_profiles(const char* file) {
    XF_TRY
    auto* factory = DomainParticipantFactory::get_instance();
    if (file && !ok(factory->load_XML_profiles_file(file))) return -1;
    return ok(factory->load_profiles()) ? 0 : -1;
    XF_CATCH(-2)
}

}  // extern "C"
namespace {
// Whether the profile set the transports itself (then they are the user's, and kept).
bool profile_sets_transports(const DomainParticipantQos& q) {
    return !q.transport().use_builtin_transports || !q.transport().user_transports.empty();
}

// The transports and discovery of `c` on top of the user's profile (`q`), as an rmw_fastrtps node of the same
// distribution applies ROS_AUTOMATIC_DISCOVERY_RANGE and ROS_STATIC_PEERS to its participant.
void apply_discovery(DomainParticipantQos& q, const xf_participant_cfg* c) {
    const bool localhost = c->range == XF_RANGE_LOCALHOST;
    const bool off = c->range == XF_RANGE_OFF;
    const bool explicit_udp = localhost || !c->shared_memory || c->n_whitelist > 0;
    if (!profile_sets_transports(q) && explicit_udp) {
        // Built-in transports are SHM + UDPv4 (Fast DDS' default, what a ROS node runs); an interface list,
        // a LOCALHOST range or shared memory off need their own descriptors.
        q.transport().use_builtin_transports = false;
        if (c->shared_memory) {
            q.transport().user_transports.push_back(std::make_shared<transport::SharedMemTransportDescriptor>());
        }
        auto udp = std::make_shared<transport::UDPv4TransportDescriptor>();
        for (size_t i = 0; i < c->n_whitelist; ++i) udp->interfaceWhiteList.emplace_back(c->whitelist[i]);
        // rmw_fastrtps' number for LOCALHOST: participants on one host reached by unicast port probing.
        if (localhost) udp->maxInitialPeersRange = 32;
        q.transport().user_transports.push_back(udp);
    }
    auto& builtin = q.wire_protocol().builtin;
    if (localhost || off) {
        // No multicast discovery; a default unicast locator keeps Fast DDS from adding a multicast one.
        builtin.metatrafficMulticastLocatorList.clear();
        builtin.metatrafficUnicastLocatorList.push_back(rtps::Locator_t());
    }
    if (off) {
        q.allocation().participants.initial = 1;
        q.allocation().participants.maximum = 1;
        q.allocation().participants.increment = 0;
    }
    for (size_t i = 0; i < c->n_peers; ++i) {
        rtps::Locator_t peer;
        rtps::IPLocator::setIPv4(peer, std::string(c->peers[i]));
        builtin.initialPeersList.push_back(peer);
    }
}
}  // namespace
extern "C" {

xf_participant* xf_participant_new(const xf_participant_cfg* c) {
    XF_TRY
    // The user's default profile first (as rmw_fastrtps), then ours: name, discovery settings, announcements.
    DomainParticipantQos q = DomainParticipantFactory::get_instance()->get_default_participant_qos();
    q.name(c->name ? c->name : "xrce-rs");
    apply_discovery(q, c);
    auto& ann = q.wire_protocol().builtin.discovery_config.initial_announcements;
    ann.count = c->announcements;
    ann.period = ms(c->announcement_period_ms);
    // The listener lives in the handle, so the handle exists first; discovery callbacks need no status mask.
    auto* h = new xf_participant{nullptr, {}};
    h->p = DomainParticipantFactory::get_instance()->create_participant(c->domain, q, &h->discovery,
                                                                       StatusMask::none());
    if (!h->p) { delete h; return nullptr; }
    answerer_start();
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
    return ok(p->p->register_type(ts)) ? 0 : -1;
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
    // The user's default profile first, then the XRCE client's QoS (ours win: the client asked for them).
    DataWriterQos q = pub->get_default_datawriter_qos();
    apply_common(q, *qos);
    set_heartbeat_period(q, ms(qos->heartbeat_ms));
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
    if (!ok(w->w->get_publication_matched_status(s))) return -1;
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
int32_t xf_writer_unmatched_in_discovery(xf_writer* w, xf_participant* oracle, uint32_t settle_ms) {
    XF_TRY
    const std::vector<GUID_t> unmatched = unmatched_known_readers(w, oracle);
    xf_participant* mine = w->owner;
    std::lock_guard<std::mutex> g(mine->discovery.m);
    const std::set<GuidPrefix_t> unsettled = mine->discovery.unsettled(settle_ms);
    int32_t n = 0;
    for (const auto& guid : unmatched) {
        const auto& prefix = guid.guidPrefix;
        if (mine->discovery.discovered.count(prefix) == 0 || unsettled.count(prefix) != 0) ++n;
    }
    return n;
    XF_CATCH(-2)
}

// Remote participants whose discovery with `p` is still under way, so that `p` may be about to learn of
// readers a new writer should not miss: those whose endpoints are still arriving at `p` or at `oracle` (a
// participant that has run longer: what it learns, `p` learns too), and those `oracle` knows and `p` has not
// discovered yet.
int32_t xf_participant_in_discovery(xf_participant* p, xf_participant* oracle, uint32_t settle_ms) {
    XF_TRY
    std::set<GuidPrefix_t> known;
    std::set<GuidPrefix_t> unsettled;
    if (oracle != p) {
        std::lock_guard<std::mutex> g(oracle->discovery.m);
        known = oracle->discovery.participants;
        unsettled = oracle->discovery.unsettled(settle_ms);
    }
    std::lock_guard<std::mutex> g(p->discovery.m);
    for (const auto& prefix : p->discovery.unsettled(settle_ms)) unsettled.insert(prefix);
    for (const auto& prefix : known) {
        if (p->discovery.participants.count(prefix) == 0) unsettled.insert(prefix);
    }
    return static_cast<int32_t>(unsettled.size());
    XF_CATCH(-2)
}

// Participants `oracle` has discovered (the agent's own included) and `oracle` itself that `p` has not
// discovered: each answered p's first announcement once, and Fast DDS drops what arrives before p's receivers
// are registered, which happens after that announcement (RTPSParticipantImpl::enable). Such a participant
// stays unknown to p until its next periodic announcement (3 s by default).
// Remote readers on `topic` that `p` has discovered and not seen leave (< 0: error).
int32_t xf_participant_known_readers(xf_participant* p, const char* topic) {
    XF_TRY
    const std::string name(topic ? topic : "");
    std::lock_guard<std::mutex> g(p->discovery.m);
    int32_t n = 0;
    for (const auto& kv : p->discovery.readers) {
        if (kv.second.topic == name) ++n;
    }
    return n;
    XF_CATCH(-2)
}

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
        if (announce_again(x)) ++n;
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
    if (!xf::write(w->w, &d, wp)) return -1;
    if (written) put_si(wp.sample_identity(), written);
    return 0;
    XF_CATCH(-2)
}

int xf_writer_wait_acked(xf_writer* w, uint32_t wait_ms) {
    XF_TRY
    return ok(w->w->wait_for_acknowledgments(ms(wait_ms))) ? 0 : -1;
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
    DataReaderQos q = sub->get_default_datareader_qos();
    apply_common(q, *qos);
    set_initial_acknack_delay(q, ms(qos->acknack_delay_ms));
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
    if (!ok(r->r->get_subscription_matched_status(s))) return -1;
    return s.current_count;
    XF_CATCH(-2)
}

// Takes one sample: 1 taken (info filled, info->body points into the reader's scratch until the next take),
// 0 none, < 0 error. Not thread-safe per reader (the Rust side serializes takes).
int xf_take(xf_reader* r, xf_take_info* info) {
    XF_TRY
    SampleInfo si;
    ReturnCode_t rc = r->r->take_next_sample(&r->scratch, &si);
    if (no_data(rc)) return 0;
    if (!ok(rc)) return -1;
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
