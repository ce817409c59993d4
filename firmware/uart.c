/* uart.c - USART0 at BAUD, 8N1: bytes in and out through two ring buffers.
 *
 * The receive interrupt stores every byte as it arrives, so the main loop may be busy for a
 * while (preparing a move) without losing any; the data-register-empty interrupt sends. */
#include <avr/io.h>
#include <avr/interrupt.h>

#include "config.h"
#include "uart.h"

#define RX_SIZE 128                  /* powers of two: the index wraps with a mask */
#define TX_SIZE 128

static volatile uint8_t rx_buf[RX_SIZE], tx_buf[TX_SIZE];
static volatile uint8_t rx_head, rx_tail, tx_head, tx_tail;

void uart_init(void)
{
    /* Double speed (U2X): UBRR = F_CPU / (8 * BAUD) - 1, rounded; 16 for 115 200 at 16 MHz. */
    UBRR0 = (uint16_t)((F_CPU + 4UL * BAUD) / (8UL * BAUD) - 1UL);
    UCSR0A = _BV(U2X0);
    UCSR0C = _BV(UCSZ01) | _BV(UCSZ00);                 /* 8 data bits, no parity, 1 stop */
    UCSR0B = _BV(RXEN0) | _BV(TXEN0) | _BV(RXCIE0);
}

ISR(USART0_RX_vect)
{
    uint8_t byte = UDR0;
    sei();                           /* read: the step interrupt need not wait for the rest */
    uint8_t next = (rx_head + 1) & (RX_SIZE - 1);
    if (next != rx_tail) {           /* a full buffer drops the byte: the CRC will catch it */
        rx_buf[rx_head] = byte;
        rx_head = next;
    }
}

ISR(USART0_UDRE_vect)
{
    if (tx_head == tx_tail) {
        UCSR0B &= (uint8_t)~_BV(UDRIE0);                /* nothing left: stop asking */
        return;
    }
    UDR0 = tx_buf[tx_tail];
    tx_tail = (tx_tail + 1) & (TX_SIZE - 1);
    sei();                           /* sent: the step interrupt need not wait for the rest */
}

int16_t uart_getc(void)
{
    if (rx_head == rx_tail)
        return -1;
    uint8_t byte = rx_buf[rx_tail];
    rx_tail = (rx_tail + 1) & (RX_SIZE - 1);
    return byte;
}

void uart_putc(uint8_t byte)
{
    uint8_t next = (tx_head + 1) & (TX_SIZE - 1);
    while (next == tx_tail)
        ;                            /* the interrupt frees a slot */
    tx_buf[tx_head] = byte;
    tx_head = next;
    UCSR0B |= _BV(UDRIE0);
}
