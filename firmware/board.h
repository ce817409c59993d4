/* board.h - Arduino Mega 2560 + RAMPS 1.4: which AVR port bit each connector pin is.
 *
 * Arduino pin numbers (D54, D38, ...) are those printed on the Mega and used by the 000 thesis
 * (Table 7) and by RAMPS documentation; the AVR port and bit of each come from the ATmega2560
 * data sheet and the Mega's schematic. Only the pins the firmware uses are listed.
 */
#ifndef BOARD_H
#define BOARD_H

#include <avr/io.h>

/* Stepper driver sockets: STEP, DIR and ENABLE (ENABLE is active low on A4988 / DRV8825). */
/* X socket: STEP D54 = PF0, DIR D55 = PF1, ENABLE D38 = PD7 */
#define RAMPS_X_STEP_PORT   PORTF
#define RAMPS_X_STEP_DDR    DDRF
#define RAMPS_X_STEP_BIT    0
#define RAMPS_X_DIR_PORT    PORTF
#define RAMPS_X_DIR_DDR     DDRF
#define RAMPS_X_DIR_BIT     1
#define RAMPS_X_EN_PORT     PORTD
#define RAMPS_X_EN_DDR      DDRD
#define RAMPS_X_EN_BIT      7
/* Y socket: STEP D60 = PF6, DIR D61 = PF7, ENABLE D56 = PF2 */
#define RAMPS_Y_STEP_PORT   PORTF
#define RAMPS_Y_STEP_DDR    DDRF
#define RAMPS_Y_STEP_BIT    6
#define RAMPS_Y_DIR_PORT    PORTF
#define RAMPS_Y_DIR_DDR     DDRF
#define RAMPS_Y_DIR_BIT     7
#define RAMPS_Y_EN_PORT     PORTF
#define RAMPS_Y_EN_DDR      DDRF
#define RAMPS_Y_EN_BIT      2
/* Z socket: STEP D46 = PL3, DIR D48 = PL1, ENABLE D62 = PK0 */
#define RAMPS_Z_STEP_PORT   PORTL
#define RAMPS_Z_STEP_DDR    DDRL
#define RAMPS_Z_STEP_BIT    3
#define RAMPS_Z_DIR_PORT    PORTL
#define RAMPS_Z_DIR_DDR     DDRL
#define RAMPS_Z_DIR_BIT     1
#define RAMPS_Z_EN_PORT     PORTK
#define RAMPS_Z_EN_DDR      DDRK
#define RAMPS_Z_EN_BIT      0
/* E0 socket (the 000 mill's tool-changer carousel): STEP D26 = PA4, DIR D28 = PA6, ENABLE D24 = PA2 */
#define RAMPS_E0_STEP_PORT  PORTA
#define RAMPS_E0_STEP_DDR   DDRA
#define RAMPS_E0_STEP_BIT   4
#define RAMPS_E0_DIR_PORT   PORTA
#define RAMPS_E0_DIR_DDR    DDRA
#define RAMPS_E0_DIR_BIT    6
#define RAMPS_E0_EN_PORT    PORTA
#define RAMPS_E0_EN_DDR     DDRA
#define RAMPS_E0_EN_BIT     2

/* E1 socket (a fifth axis): STEP D36 = PC1, DIR D34 = PC3, ENABLE D30 = PC7 */
#define RAMPS_E1_STEP_PORT  PORTC
#define RAMPS_E1_STEP_DDR   DDRC
#define RAMPS_E1_STEP_BIT   1
#define RAMPS_E1_DIR_PORT   PORTC
#define RAMPS_E1_DIR_DDR    DDRC
#define RAMPS_E1_DIR_BIT    3
#define RAMPS_E1_EN_PORT    PORTC
#define RAMPS_E1_EN_DDR     DDRC
#define RAMPS_E1_EN_BIT     7

/* Endstop connectors (inputs with the AVR pull-up on). */
/* X-min D3 = PE5, X-max D2 = PE4, Y-min D14 = PJ1, Y-max D15 = PJ0, Z-min D18 = PD3, Z-max D19 = PD2 */
#define RAMPS_XMIN_PIN  PINE
#define RAMPS_XMIN_PORT PORTE
#define RAMPS_XMIN_BIT  5
#define RAMPS_XMAX_PIN  PINE
#define RAMPS_XMAX_PORT PORTE
#define RAMPS_XMAX_BIT  4
#define RAMPS_YMIN_PIN  PINJ
#define RAMPS_YMIN_PORT PORTJ
#define RAMPS_YMIN_BIT  1
#define RAMPS_YMAX_PIN  PINJ
#define RAMPS_YMAX_PORT PORTJ
#define RAMPS_YMAX_BIT  0
#define RAMPS_ZMIN_PIN  PIND
#define RAMPS_ZMIN_PORT PORTD
#define RAMPS_ZMIN_BIT  3
#define RAMPS_ZMAX_PIN  PIND
#define RAMPS_ZMAX_PORT PORTD
#define RAMPS_ZMAX_BIT  2

/* The spindle indexer on the two free external-interrupt pins of the AUX / I2C header:
 * ICLK (encoder clock) on D21 = PD0 = INT0, SIND (indexer start, once a revolution) on
 * D20 = PD1 = INT1. */
#define ICLK_PORT   PORTD
#define ICLK_BIT    0
#define SIND_PORT   PORTD
#define SIND_BIT    1

/* Spindle and coolant: D10 = PB4 = OC2A (spindle speed PWM, as in the 000 thesis),
 * D11 = PB5 (spindle direction, servo header), D9 = PH6 (flood coolant), D8 = PH5 (mist). */
#define SPINDLE_PWM_DDR   DDRB
#define SPINDLE_PWM_BIT   4
#define SPINDLE_DIR_PORT  PORTB
#define SPINDLE_DIR_DDR   DDRB
#define SPINDLE_DIR_BIT   5
#define FLOOD_PORT        PORTH
#define FLOOD_DDR         DDRH
#define FLOOD_BIT         6
#define MIST_PORT         PORTH
#define MIST_DDR          DDRH
#define MIST_BIT          5

/* The Mega's LED, D13 = PB7: lit while a motion command executes. */
#define LED_PORT  PORTB
#define LED_DDR   DDRB
#define LED_BIT   7

#endif
