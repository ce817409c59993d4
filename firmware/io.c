/* io.c - Timer3 as a 1 ms clock, the spindle (PWM on D10, direction on D11), coolant, the LED,
 * and the stall guard.
 *
 * The clock's interrupt also samples the switches (switches.c debounces them) and watches the
 * main loop: when the loop has not looked in for STALL_MS, the steppers are stopped - the step
 * timer and the encoder's interrupts off, the step pins low, the drivers disabled (ENABLE high) -
 * with the spindle and the coolant, and the watchdog resets the board 15 ms later. The hardware
 * watchdog (main.c, 120 ms) covers a loop stuck with the interrupts off, where this interrupt
 * cannot run either; then the step interrupt is stopped too. */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/wdt.h>
#include <util/atomic.h>

#include "board.h"
#include "config.h"
#include "io.h"
#include "switches.h"

#define STALL_MS 50                /* the main loop turns in well under 1 ms */

#define PASTE(a, b, c) a##b##c
#define PIN_OF(slot, what) PASTE(RAMPS_, slot, what)
#define DRIVER_OFF(i, slot)                                                     \
    PIN_OF(slot, _STEP_PORT) &= (uint8_t)~_BV(PIN_OF(slot, _STEP_BIT));         \
    PIN_OF(slot, _EN_PORT) |= _BV(PIN_OF(slot, _EN_BIT));

static volatile uint16_t millis;
static volatile uint8_t quiet_ms;  /* milliseconds since the main loop last looked in */

/* The main loop has hung: everything that moves stops, then the watchdog resets the board. */
static void halt_outputs(void)
{
    cli();
    TIMSK1 = 0;                                        /* the step timer */
    TCCR1B = 0;
    EIMSK = 0;                                         /* the encoder's steps */
    FOR_EACH_AXIS(DRIVER_OFF)
    spindle_set(0, 0);
    coolant_set(0);
    wdt_enable(WDTO_15MS);
    wdt_reset();                                       /* (simavr starts the new time-out only here) */
    for (;;)
        ;
}

/* Interrupts stay on in here: the step interrupt's timing does not wait for the clock, and the
 * switches are sampled between steps. */
ISR(TIMER3_COMPA_vect, ISR_NOBLOCK)
{
    millis++;
    switches_sample();
    if (++quiet_ms >= STALL_MS)
        halt_outputs();
}

void io_main_loop_alive(void)
{
    quiet_ms = 0;
}

void io_init(void)
{
    TCCR3A = 0;
    OCR3A = CLOCK_TOP;                                 /* 250 counts of F_CPU / 64: 1 ms */
    TCCR3B = _BV(WGM32) | _BV(CS31) | _BV(CS30);      /* CTC on OCR3A, clock / 64 */
    TIMSK3 = _BV(OCIE3A);
    /* Spindle speed: Timer2 fast PWM on OC2A (D10), duty 0 = off. */
    SPINDLE_PWM_DDR |= _BV(SPINDLE_PWM_BIT);
    SPINDLE_DIR_DDR |= _BV(SPINDLE_DIR_BIT);
    TCCR2A = _BV(WGM21) | _BV(WGM20);                  /* the pin joins the timer when on */
    TCCR2B = _BV(CS22);                                /* clock / 64: about 1 kHz */
    OCR2A = 0;
    FLOOD_DDR |= _BV(FLOOD_BIT);
    MIST_DDR |= _BV(MIST_BIT);
    LED_DDR |= _BV(LED_BIT);
}

uint16_t io_millis(void)
{
    uint16_t now;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { now = millis; }
    return now;
}

void spindle_set(uint16_t rpm, int8_t direction)
{
    uint32_t duty = direction ? (uint32_t)rpm * 255UL / SPINDLE_MAX_RPM : 0;
    OCR2A = duty > 255 ? 255 : (uint8_t)duty;
    /* Off: the pin leaves the timer and is held low. In fast PWM a duty of 0 still gives a
     * one-count spike (4 us) every period. */
    if (duty)
        TCCR2A |= _BV(COM2A1);
    else {
        TCCR2A &= (uint8_t)~_BV(COM2A1);
        PORTB &= (uint8_t)~_BV(SPINDLE_PWM_BIT);
    }
    if (direction < 0)
        SPINDLE_DIR_PORT |= _BV(SPINDLE_DIR_BIT);      /* M4: reverse */
    else
        SPINDLE_DIR_PORT &= (uint8_t)~_BV(SPINDLE_DIR_BIT);
}

void coolant_set(uint8_t mode)
{
    if (mode == 8)
        FLOOD_PORT |= _BV(FLOOD_BIT);
    else
        FLOOD_PORT &= (uint8_t)~_BV(FLOOD_BIT);
    if (mode == 7)
        MIST_PORT |= _BV(MIST_BIT);
    else
        MIST_PORT &= (uint8_t)~_BV(MIST_BIT);
}

void led_set(uint8_t on)
{
    if (on)
        LED_PORT |= _BV(LED_BIT);
    else
        LED_PORT &= (uint8_t)~_BV(LED_BIT);
}
