/* heartbeat.h - a machine whose host fell silent brakes to a stop (docs/protocol.md §5.1). */
#ifndef HEARTBEAT_H
#define HEARTBEAT_H

/* Once a millisecond, after the link has counted the host's silence (link_tick_1ms). */
void heartbeat_tick_1ms(void);

#endif
