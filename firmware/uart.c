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

/* Both interrupts are in assembly and allow interrupts again after a dozen cycles: the step
 * interrupt's entry waits for no more than that. They save r24 (with SREG), r25, r30, r31. */
#define UART_ISR_EXIT                                                                      \
    "pop r31\n\tpop r30\n\tpop r25\n\tpop r24\n\tout __SREG__, r24\n\tpop r24\n\treti\n\t"
ISR(USART0_RX_vect, ISR_NAKED)
{
    __asm__ __volatile__(
        "push r24\n\t"
        "in r24, __SREG__\n\t"
        "push r24\n\t"
        "push r25\n\t"
        "lds r25, %[udr]\n\t"                /* read: this request is over */
        "sei\n\t"
        "push r30\n\t"
        "push r31\n\t"
        "lds r30, %[head]\n\t"
        "mov r24, r30\n\t"
        "inc r24\n\t"
        "andi r24, %[mask]\n\t"
        "lds r31, %[tail]\n\t"
        "cp r24, r31\n\t"
        "breq 1f\n\t"                        /* a full buffer drops the byte: the CRC catches it */
        "ldi r31, 0\n\t"
        "subi r30, lo8(-(%[buf]))\n\t"
        "sbci r31, hi8(-(%[buf]))\n\t"
        "st Z, r25\n\t"
        "sts %[head], r24\n\t"
        "1:\n\t"
        UART_ISR_EXIT
        ::[udr] "n"(_SFR_MEM_ADDR(UDR0)), [head] "i"(&rx_head), [tail] "i"(&rx_tail),
          [buf] "i"(rx_buf), [mask] "M"(RX_SIZE - 1));
}

/* The data register is empty: the next byte, if any. The request is switched off while this
 * runs with interrupts on, and on again after a byte is sent. */
ISR(USART0_UDRE_vect, ISR_NAKED)
{
    __asm__ __volatile__(
        "push r24\n\t"
        "in r24, __SREG__\n\t"
        "push r24\n\t"
        "lds r24, %[ucsrb]\n\t"
        "andi r24, %[off]\n\t"
        "sts %[ucsrb], r24\n\t"
        "sei\n\t"
        "push r25\n\t"
        "push r30\n\t"
        "push r31\n\t"
        "lds r30, %[tail]\n\t"
        "lds r25, %[head]\n\t"
        "cp r30, r25\n\t"
        "breq 1f\n\t"                        /* nothing left: the request stays off */
        "mov r25, r30\n\t"
        "ldi r31, 0\n\t"
        "subi r30, lo8(-(%[buf]))\n\t"
        "sbci r31, hi8(-(%[buf]))\n\t"
        "ld r24, Z\n\t"
        "sts %[udr], r24\n\t"
        "inc r25\n\t"
        "andi r25, %[mask]\n\t"
        "sts %[tail], r25\n\t"
        "cli\n\t"
        "lds r24, %[ucsrb]\n\t"
        "ori r24, %[on]\n\t"
        "sts %[ucsrb], r24\n\t"
        "1:\n\t"
        UART_ISR_EXIT
        ::[udr] "n"(_SFR_MEM_ADDR(UDR0)), [ucsrb] "n"(_SFR_MEM_ADDR(UCSR0B)),
          [off] "M"(0xFF & ~_BV(UDRIE0)), [on] "M"(_BV(UDRIE0)), [head] "i"(&tx_head),
          [tail] "i"(&tx_tail), [buf] "i"(tx_buf), [mask] "M"(TX_SIZE - 1));
}

int16_t uart_getc(void)
{
    if (rx_head == rx_tail)
        return -1;
    uint8_t byte = rx_buf[rx_tail];
    rx_tail = (rx_tail + 1) & (RX_SIZE - 1);
    return byte;
}

uint8_t uart_tx_free(void)
{
    return (uint8_t)((tx_tail - tx_head - 1) & (TX_SIZE - 1));
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
