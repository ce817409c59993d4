/* main.c - the motion controller of 002 on an Arduino Mega 2560 with RAMPS 1.4.
 *
 * 002 runs three modules in turn - asynchronous communication, the interpreter and the
 * processor - and so does this main loop: bytes from the host become frames, answers and queued
 * commands (link.c, commands.c); the interpreter fetches the next command into the processor
 * (interp.c, planner.c: phase one); every millisecond the processor's speed profile and dwell
 * advance. Phase two, the stepping itself, runs in the timer interrupt (stepper.c).
 *
 * At start the firmware sends one line of text before any frame, so that a host that has just
 * opened the port knows the bootloader is over (docs/protocol.md §1):
 *   retrofit firmware machine=NAME link=3 reset=CAUSE
 * CAUSE is what MCUSR says: power-on, external (the reset pin: the USB adapter's DTR),
 * brown-out, watchdog (the main loop hung) or jtag; unknown when no flag is set (a bootloader
 * may clear them). The line holds no 0x7E or 0x7D, so a frame receiver skips it as noise. */
#include <avr/interrupt.h>
#include <avr/pgmspace.h>
#include <avr/wdt.h>

#include "heartbeat.h"
#include "interp.h"
#include "io.h"
#include "link.h"
#include "planner.h"
#include "segment.h"
#include "stepper.h"
#include "switches.h"
#include "uart.h"

#define LINK_VERSION "3"
#define LINK_BYTES_A_TURN 8

static void put_text(const char *flash_text)
{
    char c;
    while ((c = (char)pgm_read_byte(flash_text++)) != 0)
        uart_putc((uint8_t)c);
}

/* The banner, with the first reset cause MCUSR names. */
static void banner(uint8_t mcusr)
{
    static const char head[] PROGMEM =
        "\r\nretrofit firmware machine=" MACHINE_NAME " link=" LINK_VERSION " reset=";
    static const char causes[][10] PROGMEM = {"power-on", "external", "brown-out", "watchdog", "jtag"};
    put_text(head);
    uint8_t i = 0;
    while (i < 5 && !(mcusr & (1 << i)))
        i++;
    put_text(i < 5 ? causes[i] : PSTR("unknown"));
    put_text(PSTR("\r\n"));
}

int main(void)
{
    uint8_t mcusr = MCUSR;
    MCUSR = 0;
    wdt_disable();
    uart_init();
    io_init();
    switches_init();
    stepper_init();
    link_init();
    planner_reset();
    interp_init();
    sei();
    banner(mcusr);
    wdt_enable(WDTO_120MS);        /* a main loop stuck for 120 ms resets the board: steppers stop */

    uint16_t last_ms = io_millis();
    for (;;) {
        wdt_reset();
        io_main_loop_alive();
        int16_t byte;
        /* async_comm: a few bytes a turn, and only while the step interrupt has segments
         * enough, so that a host polling fast never holds the loop away from the segments,
         * the clock's work and the watchdog (bytes wait in the receive buffer) */
        for (uint8_t n = 0; n < LINK_BYTES_A_TURN && segment_fed() && link_can_receive() &&
                            (byte = uart_getc()) >= 0; n++)
            link_receive((uint8_t)byte);
        interp_run();                                  /* interpret */
        uint16_t now = io_millis();
        while (last_ms != now) {                       /* processing: time-driven parts */
            last_ms++;
            link_tick_1ms();                           /* the host's silence, */
            heartbeat_tick_1ms();                      /* and a stop when it lasts */
            interp_tick_1ms();
        }
    }
}
