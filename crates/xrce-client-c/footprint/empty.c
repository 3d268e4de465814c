/* Footprint baseline: the same start-up, libc and link flags as publisher.c, no client. */
int main(void) {
    return 0;
}
