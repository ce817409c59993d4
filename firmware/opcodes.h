/* opcodes.h - the command set's opcodes (docs/protocol.md §7). Generated from
 * retrofit/link/codec.py's OPCODES by `python3 -m retrofit.link.header`: do not edit. */
#ifndef OPCODES_H
#define OPCODES_H

#define OP_INIT  0x01
#define OP_FMOV  0x02
#define OP_ZMOV  0x03
#define OP_PMOV  0x04
#define OP_STOP  0x05
#define OP_FFDR  0x06
#define OP_MFDR  0x07
#define OP_PFDR  0x08
#define OP_DELY  0x09
#define OP_CSTP  0x0A
#define OP_ISTP  0x0B
#define OP_PSTN  0x0C
#define OP_RDPS  0x0D
#define OP_RDST  0x0E
#define OP_SPIN  0x0F
#define OP_COOL  0x10
#define OP_PROB  0x11

#define PROB_UNTIL_OPEN 0x01       /* PROB's flags: move until the probe input opens (G38.4/5) */

#endif
