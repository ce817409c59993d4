/* uart.h - USART0 (the Mega's USB serial, pins D0/D1) with interrupt-driven ring buffers. */
#ifndef UART_H
#define UART_H

#include <stdint.h>

void uart_init(void);
/* Next received byte, or -1 when none is waiting. */
int16_t uart_getc(void);
/* Queue one byte for sending; waits only if the 128-byte transmit buffer is full. */
void uart_putc(uint8_t byte);
/* Bytes the transmit buffer can take now without waiting. */
uint8_t uart_tx_free(void);

#endif
