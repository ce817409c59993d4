/* commands.h - the command set of 002 as the firmware holds it, and the three-deep queue (commands.c):
 * the opcodes, the decoded command and the queue, each in a header of its own. */
#ifndef COMMANDS_H
#define COMMANDS_H

#include "opcodes.h"       /* generated from the host's table: python3 -m retrofit.link.header */
#include "command.h"
#include "queue.h"

#endif
