/* Footprint baseline: the same start-up, board support and link as fp_publisher.c, no client. */
#include "board.h"

int main(void) {
    board_init();
    board_print("baseline\n");
    board_report("peak stack: ", (uint32_t)board_stack_used());
    return 0;
}
