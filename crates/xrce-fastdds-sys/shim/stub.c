/* The shim's C ABI without Fast DDS: built when libfastrtps-dev is not installed, so that the workspace (and
 * `cargo test --all-features`) still builds. Every constructor fails; xf_available() tells the Rust side why.
 * It must define every function src/ffi.rs declares: the test `stub_defines_every_shim_function` checks it. */
#include <stddef.h>
#include <stdint.h>

int xf_available(void) { return 0; }
int xf_load_profiles(const char *file) { (void)file; return 0; }
void *xf_participant_new(const void *cfg) { (void)cfg; return NULL; }
void xf_participant_delete(void *p) { (void)p; }
void xf_participant_guid(const void *p, void *out) { (void)p; (void)out; }
int xf_register_type(void *p, const char *t, uint8_t k) { (void)p; (void)t; (void)k; return -1; }
void *xf_topic_new(void *p, const char *n, const char *t) { (void)p; (void)n; (void)t; return NULL; }
void xf_topic_delete(void *p, void *t) { (void)p; (void)t; }
void *xf_writer_new(void *p, void *t, const void *q, const char *const *parts, size_t n) {
    (void)p; (void)t; (void)q; (void)parts; (void)n; return NULL;
}
void xf_writer_delete(void *p, void *w) { (void)p; (void)w; }
void xf_writer_guid(const void *w, void *out) { (void)w; (void)out; }
int32_t xf_writer_matched(void *w) { (void)w; return 0; }
int32_t xf_writer_unmatched_known(void *w, void *o) { (void)w; (void)o; return 0; }
int32_t xf_writer_unmatched_in_discovery(void *w, void *o, uint32_t s) { (void)w; (void)o; (void)s; return 0; }
int32_t xf_writer_matched_prefix(void *w, const uint8_t *prefix) { (void)w; (void)prefix; return 0; }
int32_t xf_participant_in_discovery(void *p, void *o, uint32_t s) { (void)p; (void)o; (void)s; return 0; }
int32_t xf_participant_undiscovered(void *p, void *o) { (void)p; (void)o; return 0; }
int32_t xf_participant_known_readers(void *p, const char *t) { (void)p; (void)t; return 0; }
int32_t xf_participant_reannounce_unheard(void *p) { (void)p; return 0; }
int xf_write(void *w, const uint8_t *b, size_t l, const void *r, void *o) {
    (void)w; (void)b; (void)l; (void)r; (void)o; return -1;
}
int xf_writer_wait_acked(void *w, uint32_t ms) { (void)w; (void)ms; return 0; }
void *xf_reader_new(void *p, void *t, const void *q, const char *const *parts, size_t n, void (*cb)(void *), void *ctx) {
    (void)p; (void)t; (void)q; (void)parts; (void)n; (void)cb; (void)ctx; return NULL;
}
void xf_reader_delete(void *p, void *r) { (void)p; (void)r; }
void xf_reader_guid(const void *r, void *out) { (void)r; (void)out; }
int32_t xf_reader_matched(void *r) { (void)r; return 0; }
int xf_take(void *r, void *info) { (void)r; (void)info; return -1; }
