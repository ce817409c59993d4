/* main.c - the motion controller of 002 on an Arduino Mega 2560 with RAMPS 1.4.
 *
 * 002 runs three modules in turn - asynchronous communication, the interpreter and the
 * processor - and so does this main loop: bytes from the host become frames, answers and queued
 * commands (link.c, commands.c); the interpreter fetches the next command into the processor
 * (interp.c, planner.c: phase one); every millisecond the processor's speed profile and dwell
 * advance. Phase two, the stepping itself, runs in the timer interrupt (stepper.c). */
#include <avr/interrupt.h>
#include <avr/wdt.h>

#include "interp.h"
#include "io.h"
#include "link.h"
#include "planner.h"
#include "stepper.h"
#include "switches.h"
#include "uart.h"

int main(void)
{
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
    wdt_enable(WDTO_120MS);        /* a main loop stuck for 120 ms resets the board: steppers stop */

    uint16_t last_ms = io_millis();
    for (;;) {
        wdt_reset();
        int16_t byte;
        while ((byte = uart_getc()) >= 0)             /* async_comm */
            link_receive((uint8_t)byte);
        interp_run();                                  /* interpret */
        uint16_t now = io_millis();
        while (last_ms != now) {                       /* processing: time-driven parts */
            last_ms++;
            interp_tick_1ms();
        }
    }
}
