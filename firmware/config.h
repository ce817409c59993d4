/* config.h - the firmware's settings: the machine's (generated header) and the board's.
 *
 * The machine header (machines/NAME.h, chosen with `make MACHINE=NAME`) is written from the
 * retrofit machine file by tools/machine_header.py, so steps/mm, speeds, pulse timing and the
 * switch wiring are the ones the Python side plans with. Everything here is a compile-time
 * constant; the firmware has no settings block in EEPROM.
 */
#ifndef CONFIG_H
#define CONFIG_H

#include <stdint.h>

#ifndef MACHINE_HEADER
#define MACHINE_HEADER "machines/mitic-lathe.h"
#endif
#include MACHINE_HEADER

#ifndef F_CPU
#define F_CPU 16000000UL              /* the Mega's crystal */
#endif
#ifndef BAUD
#define BAUD 115200UL                 /* docs/protocol.md §1: 8N1, 115 200 baud by default */
#endif

/* Timer1, the step cycle and the step pulse, counts F_CPU / 8 = 2 MHz: 0.5 us a count. Timer3
 * is the 1 ms clock. (Only Timer1 and Timer3 are used: QEMU 7.2 routes the interrupts of Timer4
 * and Timer5 to the wrong vectors, and the firmware must run there too.) */
#define TIMER_HZ          (F_CPU / 8UL)
#define US_TO_COUNTS(us)  ((uint16_t)((us) * (TIMER_HZ / 1000000UL)))
#define CLOCK_TOP         ((uint16_t)(F_CPU / 64UL / 1000UL - 1UL))

/* The link (docs/protocol.md): at most 32 payload bytes, a 36-byte body, three queued commands. */
#define MAX_PAYLOAD   32
#define QUEUE_DEPTH   3               /* 002: "three commands in advance" */

/* Slowest and fastest step-cycle rates the timer is asked for (events per second). */
#define MIN_RATE      2.0f
#define MAX_RATE      (1000000.0f / (float)MIN_PERIOD_US)

#if N_AXES < 1 || N_AXES > 5
#error "the firmware drives 1 to 5 axes (the RAMPS X, Y, Z, E0 and E1 sockets)"
#endif
#if PULSE_HIGH_US < 1 || PULSE_HIGH_US >= MIN_PERIOD_US
#error "the step pulse must be at least 1 us and shorter than the shortest step period"
#endif
#if PULSE_HIGH_US > 30000 || DIR_SETUP_US > 30000
#error "pulse width and direction set-up must fit a 16-bit timer cycle (30 ms)"
#endif
#if MIN_PERIOD_US - PULSE_HIGH_US < 10
#error "the step period must leave at least 10 us low after the pulse"
#endif
#if DIR_SETUP_US > MIN_PERIOD_US - PULSE_HIGH_US
#error "a direction changes at a pulse's end: its set-up must fit the low part of the shortest period"
#endif

/* How far a joint taken at speed may round the corner (the host planner's junction_deviation_mm). */
#ifndef JUNCTION_DEVIATION_MM
#define JUNCTION_DEVIATION_MM 0.01f
#endif

#endif
