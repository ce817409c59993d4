/* io.h - the millisecond clock, spindle and coolant outputs, and the LED. */
#ifndef IO_H
#define IO_H

#include <stdint.h>

void io_init(void);
uint16_t io_millis(void);                      /* wraps every 65.536 s */
void io_main_loop_alive(void);                 /* the stall guard: call every turn of the loop */
void spindle_set(uint16_t rpm, int8_t direction);   /* direction +1 M3, -1 M4, 0 stopped */
void coolant_set(uint8_t mode);                /* 0 off, 7 mist, 8 flood */
void led_set(uint8_t on);

#endif
