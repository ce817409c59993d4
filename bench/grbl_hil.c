/* grbl_hil.c - a grbl build for the ATmega328P (16 MHz) in simavr, fed G-code over its USART.
 *
 *   grbl_hil GRBL.elf PROGRAM.gcode LOG MAX_CYCLES
 *
 * Waits for grbl's start line, then streams the program's lines with grbl's character-counting
 * rule (the bytes of the lines not yet answered "ok" or "error" stay within its 128-byte receive
 * buffer; a line starting with '$' goes alone, as it writes the EEPROM). Every change of port D
 * (steps on PD2-PD4, directions on PD5-PD7) is written to LOG as "P CYCLE D VALUE" (hex), the
 * form retrofit/firmware/sim.py reads. Stops when every line is answered and port D has not
 * changed for 100 ms of AVR time since then, or at MAX_CYCLES; prints every line grbl sent other
 * than "ok" and "end cycles=N ok=N error=N".
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <simavr/avr_ioport.h>
#include <simavr/avr_uart.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_elf.h>
#include <simavr/sim_irq.h>

#define RX_BUFFER 127                     /* grbl's RX_BUFFER_SIZE (128) less one */
#define QUIET_CYCLES 1600000ULL           /* 100 ms at 16 MHz */

static avr_t *avr;
static FILE *log_file;
static uint8_t port_d;
static unsigned long long last_change;
static int xon = 1, started, oks, errors;
static char reply[256];
static size_t reply_len;
static size_t outstanding[512], n_out, out_bytes;

static void port_changed(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq; (void)param;
    if ((uint8_t)value == port_d)
        return;
    port_d = (uint8_t)value;
    last_change = avr->cycle;
    fprintf(log_file, "P %llu D %02x\n", (unsigned long long)avr->cycle, port_d);
}

/* A line from grbl: its banner starts the stream; "ok" / "error:N" free the oldest line's bytes. */
static void uart_out(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq; (void)param;
    char c = (char)value;
    if (c != '\n') {
        if (c != '\r' && reply_len < sizeof reply - 1)
            reply[reply_len++] = c;
        return;
    }
    reply[reply_len] = 0;
    reply_len = 0;
    if (!strncmp(reply, "Grbl ", 5))
        started = 1;
    int ok = !strcmp(reply, "ok"), err = !strncmp(reply, "error", 5);
    if (!ok && reply[0])
        printf("grbl: %s\n", reply);
    if ((ok || err) && n_out) {
        out_bytes -= outstanding[0];
        memmove(outstanding, outstanding + 1, --n_out * sizeof outstanding[0]);
        oks += ok;
        errors += err;
    }
}

/* simavr's timer makes no compare match while OCR1A is 0, where the chip (CTC, top 0) matches
 * at once; grbl's first stepper interrupt, which sets OCR1A, relies on that. While the interrupt
 * is on and OCR1A is 0 the harness writes 1 through the timer's own register path: the match
 * comes a cycle or two later than on the chip. */
#define TIMSK1 0x6F
#define TCCR1B 0x81
#define OCR1AL 0x88
static void ocr1a_zero(void)
{
    if ((avr->data[TIMSK1] & 0x02) && (avr->data[TCCR1B] & 0x07) && !avr->data[OCR1AL]
        && !avr->data[OCR1AL + 1]) {
        int io = AVR_DATA_TO_IO(OCR1AL);
        if (avr->io[io].w.c)
            avr->io[io].w.c(avr, OCR1AL, 1, avr->io[io].w.param);
    }
}

/* grbl ends a step pulse with Timer0's overflow: it presets TCNT0, then starts the clock. simavr
 * counts from 0 whenever a timer's clock starts (a pulse of 128 us instead of a few), so once the
 * clock is on the harness writes the preset again through the timer's own path, as on the chip. */
#define TCNT0 0x46
#define TCCR0B 0x45
static uint8_t tcnt0_preset, tccr0b_was;
static void tcnt0_written(avr_t *a, avr_io_addr_t addr, uint8_t v, void *param)
{
    (void)a; (void)addr; (void)param;
    tcnt0_preset = v;
}

static void tccr0b_written(avr_t *a, avr_io_addr_t addr, uint8_t v, void *param)
{
    (void)addr; (void)param;
    int started = (v & 0x07) && !(tccr0b_was & 0x07);
    tccr0b_was = v;
    int io = AVR_DATA_TO_IO(TCNT0);
    if (started && a->io[io].w.c)
        a->io[io].w.c(a, TCNT0, tcnt0_preset, a->io[io].w.param);
}

static void uart_xon(struct avr_irq_t *irq, uint32_t value, void *param) { (void)irq; (void)value; (void)param; xon = 1; }
static void uart_xoff(struct avr_irq_t *irq, uint32_t value, void *param) { (void)irq; (void)value; (void)param; xon = 0; }

int main(int argc, char **argv)
{
    if (argc != 5) {
        fprintf(stderr, "usage: grbl_hil GRBL.elf PROGRAM.gcode LOG MAX_CYCLES\n");
        return 2;
    }
    elf_firmware_t fw;
    memset(&fw, 0, sizeof fw);
    if (elf_read_firmware(argv[1], &fw)) {
        fprintf(stderr, "grbl_hil: %s: cannot read the ELF\n", argv[1]);
        return 2;
    }
    FILE *program = fopen(argv[2], "r");
    log_file = fopen(argv[3], "w");
    if (!program || !log_file) {
        fprintf(stderr, "grbl_hil: cannot open %s or %s\n", argv[2], argv[3]);
        return 2;
    }
    unsigned long long max_cycles = strtoull(argv[4], NULL, 10);
    avr = avr_make_mcu_by_name("atmega328p");
    avr_init(avr);
    avr->log = 0;
    fw.frequency = 16000000;
    avr_load_firmware(avr, &fw);
    avr->frequency = 16000000;
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('D'), IOPORT_IRQ_PIN_ALL), port_changed, NULL);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT), uart_out, NULL);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XON), uart_xon, NULL);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF), uart_xoff, NULL);
    uint32_t flags = 0;
    avr_ioctl(avr, AVR_IOCTL_UART_GET_FLAGS('0'), &flags);
    flags &= ~AVR_UART_FLAG_STDIO;
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
    avr_irq_t *in = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
    avr_register_io_write(avr, TCNT0, tcnt0_written, NULL);
    avr_register_io_write(avr, TCCR0B, tccr0b_written, NULL);
    /* The switches grbl reads, released: limits on PB1-PB4, reset / feed hold / cycle start and
     * the probe on PC0-PC5, all active low behind the pull-ups. */
    avr_ioport_external_t high_b = {.name = 'B', .mask = 0x1E, .value = 0x1E};
    avr_ioport_external_t high_c = {.name = 'C', .mask = 0x3F, .value = 0x3F};
    avr_ioctl(avr, AVR_IOCTL_IOPORT_SET_EXTERNAL('B'), &high_b);
    avr_ioctl(avr, AVR_IOCTL_IOPORT_SET_EXTERNAL('C'), &high_c);
    for (int bit = 0; bit < 6; bit++) {
        if (bit >= 1 && bit <= 4)
            avr_raise_irq(avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('B'), bit), 1);
        avr_raise_irq(avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('C'), bit), 1);
    }

    char line[256], *pending = NULL;
    size_t pos = 0, len = 0;
    int done_reading = 0, dollar = 0, state = cpu_Running;
    while (state != cpu_Done && state != cpu_Crashed && avr->cycle < max_cycles) {
        if (started && !pending && !done_reading) {
            if (fgets(line, sizeof line, program)) {
                pending = line;
                len = strlen(line);
                pos = 0;
            } else
                done_reading = 1;
        }
        if (pending && pos == 0) {                /* may the whole line go now? */
            int alone = pending[0] == '$';
            if (out_bytes + len > RX_BUFFER || ((alone || dollar) && n_out) || n_out >= 512)
                goto run;
            dollar = alone;
            outstanding[n_out++] = len;
            out_bytes += len;
        }
        while (pending && xon && pos < len)
            avr_raise_irq(in, (uint8_t)pending[pos++]);
        if (pending && pos == len)
            pending = NULL;
    run:
        ocr1a_zero();
        state = avr_run(avr);
        if (!done_reading || pending || n_out)
            last_change = avr->cycle > last_change ? avr->cycle : last_change;
        else if (avr->cycle - last_change > QUIET_CYCLES)
            break;
    }
    printf("end cycles=%llu ok=%d error=%d state=%d\n", (unsigned long long)avr->cycle, oks, errors, state);
    fclose(log_file);
    return state == cpu_Crashed ? 3 : 0;
}
