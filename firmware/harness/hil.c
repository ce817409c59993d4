/* hil.c - the compiled firmware in simavr's cycle-exact ATmega2560, its pins wired to a machine.
 *
 *   hil FIRMWARE.elf [options]
 *
 * USART0 is served on a TCP port (--listen HOST:PORT, one client at a time) or fed from a script
 * of bytes at given cycles (--script FILE: lines "CYCLE HEXBYTES"). Every change of the output
 * ports A, B, C, D, F, H, K, L and every byte the firmware sends is written to --log FILE as text lines
 *   P CYCLE PORT VALUE      (port letter, the 8-bit output value in hex)
 *   U CYCLE BYTE            (a byte on the USART's TX, hex)
 *   I CYCLE PORT BIT LEVEL  (an input the harness drove)
 *   R CYCLE TICK RPM        (the spindle drive's new speed, --spindle-model: signed, M4 negative)
 * so the Python side (retrofit/firmware/sim.py) decodes the step pins with retrofit's own driver
 * model. The harness keeps a step count per axis itself (--axis STEP,DIR,INVERT_DIR) so that
 * switches (--switch PIN,AXIS,<|>,STEPS,ACTIVE_LEVEL) open and close at a step count within the
 * same cycle, drives a tool setter's beam (--beam PIN,LEVEL[,AXIS,LO,HI,AXIS,LO,HI,AXIS,LO,HI]:
 * the pin at LEVEL while every named axis's count lies within LO..HI, at the other level outside
 * or without a box - no tool in the spindle), and drives the spindle encoder (--spindle RPM,COUNTS_PER_REV: ICLK on PD0, SIND on
 * PD1; or --spindle-model: the firmware's own spindle outputs drive a model of the spindle). --stats prints interrupt figures at the end: the longest stretch with interrupts off
 * outside and inside ISRs (with the program counter where the longest one outside began, and
 * where the longest one inside began and ended), and
 * the cycles spent in ISRs. The end line names the program counter the run stopped at. --vcd FILE writes the step ports as VCD.
 * The simulated time runs at most --speed times wall time (0: unpaced; default 1 with --listen).
 * It stops after --cycles N, at SIGTERM / SIGINT, or when a --listen client hangs up (--once).
 * --boot-ms N plays the Mega's bootloader after a DTR reset: for N ms the CPU spins outside the
 * firmware and what the client sends is lost; then the firmware starts (MCUSR: external reset).
 * Without it the firmware starts at once after a power-on (MCUSR: PORF).
 * --pipe runs in lockstep with the process that started it: stdin gives "B HEXBYTES" (bytes for the
 * USART now) and "R CYCLE" (run until then), stdout answers "U CYCLE BYTE" for each byte sent and
 * "A CYCLE" when it got there; the run ends at EOF. The AVR's time is then the host's only clock.
 * Each "U" line ends with every axis's step count (--axis order) at that cycle; "W CYCLE" runs
 * like "R CYCLE" but stops early just after the firmware sends a 0x7E (a frame's flag), so a
 * host may grant long stretches and still see each answer at once. --no-port-log leaves the P
 * lines out of the log (a long run that checks its steps on the "U" lines' counts).
 * --glitch PIN,CYCLE,CYCLES,LEVEL drives an input to LEVEL for CYCLES from CYCLE, then gives it
 * back its level (a switch's bounce; repeatable). --stall CYCLE[,cli] makes the main loop hang at
 * the first instruction it runs from CYCLE on: the CPU jumps to a loop of its own (with ",cli"
 * after turning the interrupts off); the interrupts, the watchdog and a reset go on as on the chip.
 */
#define _GNU_SOURCE
#include <arpa/inet.h>
#include <errno.h>
#include <math.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <simavr/avr_extint.h>
#include <simavr/avr_ioport.h>
#include <simavr/avr_uart.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_elf.h>
#include <simavr/sim_irq.h>
#include <simavr/sim_vcd_file.h>

#define MAX_AXES 6
#define UCSR0B_ADDR 0xC1                  /* ATmega2560: USART0 control register B */
#define RXEN0_BIT 0x10
#define MAX_SWITCHES 16
#define RX_FIFO 65536

static avr_t *avr;
static FILE *log_file;
static int log_ports = 1;                 /* --no-port-log: no P lines */
static volatile sig_atomic_t stop_now;

/* ---- the machine on the pins ----------------------------------------------------------- */

typedef struct { char port; int bit; } pin_t;
typedef struct { pin_t step, dir; int invert_dir; long steps; int step_level; } axis_t;
typedef struct { pin_t pin; int axis; char side; long at; int active; int level; } sw_t;

typedef struct { pin_t pin; int level, used, n, axis[3], state; long lo[3], hi[3]; } beam_t;

static axis_t axes[MAX_AXES];
static beam_t beam;
static int n_axes;
static sw_t switches[MAX_SWITCHES];
static int n_switches;
static uint8_t out_ports[16];             /* last value of each output port, by letter - 'A' */
static double spindle_rpm;
static long spindle_counts;

/* An input the machine drives: also declared as the port's external level, so that the
 * firmware's write of a pull-up to PORTx does not override it. */
static uint8_t ext_mask[16], ext_value[16];

static void drive(pin_t p, int level)
{
    int k = p.port - 'A';
    ext_mask[k] |= (uint8_t)(1 << p.bit);
    ext_value[k] = (uint8_t)((ext_value[k] & ~(1 << p.bit)) | (level << p.bit));
    avr_ioport_external_t ext = {.name = (unsigned long)p.port, .mask = ext_mask[k], .value = ext_value[k]};
    avr_ioctl(avr, AVR_IOCTL_IOPORT_SET_EXTERNAL(p.port), &ext);
    avr_raise_irq(avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(p.port), p.bit), level);
    if (log_file)
        fprintf(log_file, "I %llu %c %d %d\n", (unsigned long long)avr->cycle, p.port, p.bit, level);
}

static void update_switches(void)
{
    for (int i = 0; i < n_switches; i++) {
        sw_t *s = &switches[i];
        long pos = axes[s->axis].steps;
        int closed = s->side == '<' ? pos <= s->at : pos >= s->at;
        int level = closed ? s->active : !s->active;
        if (level != s->level) {
            s->level = level;
            drive(s->pin, level);
        }
    }
}

/* The beam: broken (its LEVEL) while the carriages are inside its box. */
static void update_beam(void)
{
    if (!beam.used)
        return;
    int inside = beam.n > 0;
    for (int k = 0; k < beam.n; k++) {
        long pos = axes[beam.axis[k]].steps;
        inside &= pos >= beam.lo[k] && pos <= beam.hi[k];
    }
    int level = inside ? beam.level : !beam.level;
    if (level != beam.state) {
        beam.state = level;
        drive(beam.pin, level);
    }
}

/* The magazine (--seat, --pocket, --tool-box, --spindle-tool): which tool the spindle holds,
 * moved as retrofit/atc/magazine.py moves it: an empty spindle that comes down into the seat
 * (station X1, the fork's Y, down to the clamp height) over a pocket's tool clamps it; a spindle
 * that lifts out of the seat while still in the fork leaves its tool in the pocket there, if
 * that pocket is empty. The pocket is the one at the spindle when it came into the seat. With
 * a magazine the beam's box is that of the tool in the spindle (none: the beam stays clear). */
#define MAX_TOOLS 32
typedef struct { int axis[3]; long lo[3], hi[3]; int used; } box_t;
static box_t seat, tool_box[MAX_TOOLS];
static struct { long lo, hi; int tool, used; } pockets[MAX_TOOLS];
static int carousel_axis, spindle_tool, seated, seated_pocket;

static int in_box(const box_t *b)
{
    for (int k = 0; k < 3; k++) {
        long pos = axes[b->axis[k]].steps;
        if (pos < b->lo[k] || pos > b->hi[k])
            return 0;
    }
    return 1;
}

static void update_magazine(void)
{
    if (!seat.used)
        return;
    int now = in_box(&seat), p = seated_pocket;
    if (now && !seated) {
        long c = axes[carousel_axis].steps;
        p = 0;
        for (int n = 1; n < MAX_TOOLS && !p; n++)
            if (pockets[n].used && c >= pockets[n].lo && c <= pockets[n].hi)
                p = n;
        if (p && !spindle_tool && pockets[p].tool) {
            spindle_tool = pockets[p].tool;
            pockets[p].tool = 0;
        }
    } else if (!now && seated) {
        int lifted = axes[seat.axis[2]].steps > seat.hi[2];
        long y = axes[seat.axis[1]].steps;
        if (p && spindle_tool && lifted && y >= seat.lo[1] && y <= seat.hi[1] && !pockets[p].tool) {
            pockets[p].tool = spindle_tool;
            spindle_tool = 0;
        }
        p = 0;
    }
    seated = now;
    seated_pocket = p;
    if (beam.used) {
        beam.n = 0;
        if (spindle_tool > 0 && spindle_tool < MAX_TOOLS && tool_box[spindle_tool].used) {
            beam.n = 3;
            for (int k = 0; k < 3; k++) {
                beam.axis[k] = tool_box[spindle_tool].axis[k];
                beam.lo[k] = tool_box[spindle_tool].lo[k];
                beam.hi[k] = tool_box[spindle_tool].hi[k];
            }
        }
    }
}

static int parse_box(const char *v, box_t *b)
{
    int got = sscanf(v, "%d,%ld,%ld,%d,%ld,%ld,%d,%ld,%ld", &b->axis[0], &b->lo[0], &b->hi[0],
                     &b->axis[1], &b->lo[1], &b->hi[1], &b->axis[2], &b->lo[2], &b->hi[2]);
    for (int k = 0; k < 3 && got == 9; k++)
        if (b->axis[k] < 0 || b->axis[k] >= MAX_AXES)
            got = 0;
    b->used = got == 9;
    return b->used;
}

static int pin_level(pin_t p) { return (out_ports[p.port - 'A'] >> p.bit) & 1; }

static void port_changed(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    char port = (char)(intptr_t)param;
    uint8_t old = out_ports[port - 'A'];
    if (old == (uint8_t)value)
        return;
    out_ports[port - 'A'] = (uint8_t)value;
    if (log_file && log_ports)
        fprintf(log_file, "P %llu %c %02x\n", (unsigned long long)avr->cycle, port, value & 0xFF);
    int moved = 0;
    for (int i = 0; i < n_axes; i++) {
        axis_t *a = &axes[i];
        int level = pin_level(a->step);
        if (level && !a->step_level) {          /* a rising step edge: the driver steps */
            int positive = pin_level(a->dir) ^ a->invert_dir;
            a->steps += positive ? 1 : -1;
            moved = 1;
        }
        a->step_level = level;
    }
    if (moved) {
        update_switches();
        update_magazine();
        update_beam();
    }
}

/* The spindle in the loop (--spindle-model): the firmware's own outputs drive the drive model of
 * retrofit/sim/spindle.py, tick for tick with the same arithmetic, and its encoder feeds ICLK and
 * SIND back. The drive reads the speed PWM on D10 (OC2A) once a period of Timer2's PWM
 * (PWM_WINDOW cycles), its duty a share of max_rpm, and the direction on D11 (PB5, high: M4).
 * The load factors are drawn by the Python side from the machine file's seed and given in a file
 * of doubles (used in turn, from the start again when used up). --spindle-stall: the spindle is
 * jammed and never turns, whatever the firmware asks; --spindle-stall-at CYCLE: it stops dead
 * then and stays jammed. */
#define PWM_WINDOW (256UL * 64UL)
#define MAX_EDGES 64
static struct {
    int on, stalled;
    unsigned long long stall_at;          /* --spindle-stall CYCLE: jammed from then on */
    long counts, tick_cycles, interval;
    double max_rpm, ramp, tick_s, rpm, target, knot0, knot1, drive_target;
    double *draws;
    long n_draws, drawn, tick;
    long long angle;                      /* 1/65536 counts */
    unsigned long long edges[MAX_EDGES];
    int n_edges, next_edge, high;
    long count;
} sm;

static double next_draw(void)
{
    double d = sm.draws[sm.drawn % sm.n_draws];
    sm.drawn++;
    return d;
}

/* The PWM's duty as the pin has it: (OCR2A + 1) / 256 while OC2A drives the pin (fast PWM,
 * COM2A1), else the port bit. Read from the timer's registers, not from the pin's changes:
 * simavr lets any write to PORTB (the LED's, every millisecond) pull the pin to PORTB's bit
 * within the period, which the chip does not while the timer owns the pin. */
#define TCCR2A_ADDR 0xB0
#define OCR2A_ADDR 0xB3
#define PORTB_ADDR 0x25
static avr_cycle_count_t pwm_window(avr_t *a, avr_cycle_count_t when, void *param)
{
    (void)param;
    double duty = a->data[TCCR2A_ADDR] & 0x80 ? (a->data[OCR2A_ADDR] + 1) / 256.0
                                             : (double)((a->data[PORTB_ADDR] >> 4) & 1);
    int reverse = (a->data[PORTB_ADDR] >> 5) & 1;
    sm.drive_target = sm.stalled ? 0.0 : duty * sm.max_rpm * (reverse ? -1.0 : 1.0);
    return when + PWM_WINDOW;
}

static avr_cycle_count_t encoder_edge(avr_t *a, avr_cycle_count_t when, void *param)
{
    (void)a; (void)param;
    pin_t iclk = {'D', 0}, sind = {'D', 1};
    if (sm.high) {
        drive(iclk, 0);
        drive(sind, 0);
        sm.high = 0;
    } else {
        sm.count++;
        if (sm.count % sm.counts == 0)
            drive(sind, 1);
        drive(iclk, 1);
        sm.high = 1;
        sm.next_edge++;
        return when + 32;
    }
    if (sm.next_edge < sm.n_edges)
        return sm.edges[sm.next_edge] > when ? sm.edges[sm.next_edge] : when + 1;
    return 0;
}

/* One tick of SimSpindle._step: the ramp, the load, the angle; the counts it passes become
 * edges spread evenly over the tick's cycles. */
static avr_cycle_count_t drive_tick(avr_t *a, avr_cycle_count_t when, void *param)
{
    (void)param;
    long t = ++sm.tick;
    if (sm.stall_at && when >= sm.stall_at && !sm.stalled) {
        sm.stalled = 1;                   /* jammed: it stops dead */
        sm.rpm = sm.drive_target = 0.0;
    }
    if (sm.drive_target != sm.target) {
        sm.target = sm.drive_target;
        if (log_file)
            fprintf(log_file, "R %llu %ld %.17g\n", (unsigned long long)when, t, sm.target);
    }
    double delta = sm.target - sm.rpm;
    sm.rpm = fabs(delta) <= sm.ramp ? sm.target : sm.rpm + (delta > 0 ? sm.ramp : -sm.ramp);
    long phase = t % sm.interval;
    if (phase == 0 && t > 0) {
        sm.knot0 = sm.knot1;
        sm.knot1 = next_draw();
    }
    double load = sm.knot0 + (sm.knot1 - sm.knot0) * (double)phase / (double)sm.interval;
    double per_tick = fabs(sm.rpm) / 60.0 * (double)sm.counts * sm.tick_s * (1.0 + load);
    long long before = sm.angle;
    sm.angle += (long long)nearbyint(per_tick * 65536.0);
    long long first = (before >> 16) + 1, last = sm.angle >> 16;
    int pending = sm.n_edges - sm.next_edge, alive = pending > 0 || sm.high;
    memmove(sm.edges, sm.edges + sm.next_edge, (size_t)pending * sizeof sm.edges[0]);
    sm.n_edges = pending;
    sm.next_edge = 0;
    for (long long n = first; n <= last && sm.n_edges < MAX_EDGES; n++) {
        double f = (double)((n << 16) - before) / (double)(sm.angle - before);
        sm.edges[sm.n_edges++] = when + (avr_cycle_count_t)ceil(f * (double)sm.tick_cycles);
    }
    if (sm.n_edges && !alive)
        avr_cycle_timer_register(a, sm.edges[0] > a->cycle ? sm.edges[0] - a->cycle : 1, encoder_edge, NULL);
    return when + (avr_cycle_count_t)sm.tick_cycles;
}

static int spindle_model_args(const char *v)
{
    char path[512];
    if (sscanf(v, "%ld,%lf,%ld,%lf,%lf,%ld,%511s", &sm.counts, &sm.max_rpm, &sm.tick_cycles, &sm.ramp,
               &sm.tick_s, &sm.interval, path) != 7 || sm.counts < 1 || sm.tick_cycles < 1 || sm.interval < 1)
        return 0;
    FILE *f = fopen(path, "rb");
    if (!f)
        return 0;
    fseek(f, 0, SEEK_END);
    sm.n_draws = ftell(f) / (long)sizeof(double);
    fseek(f, 0, SEEK_SET);
    sm.draws = malloc((size_t)(sm.n_draws > 0 ? sm.n_draws : 1) * sizeof(double));
    if (sm.n_draws < 1 || fread(sm.draws, sizeof(double), (size_t)sm.n_draws, f) != (size_t)sm.n_draws) {
        fclose(f);
        return 0;
    }
    fclose(f);
    sm.knot0 = 0.0;
    sm.knot1 = next_draw();
    sm.tick = -1;
    sm.on = 1;
    return 1;
}

/* D10 = PB4 = OC2A, the spindle PWM: the timer drives this pin without a write to PORTB, so its
 * own level is logged as port "W" (bit 4). */
static void pwm_pin_changed(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    (void)param;
    static int last = -1;
    if ((int)(value & 1) == last)
        return;
    last = (int)(value & 1);
    if (log_file && log_ports)
        fprintf(log_file, "P %llu W %02x\n", (unsigned long long)avr->cycle, (value & 1) << 4);
}

/* ICLK pulses COUNTS times a revolution (2 us high), SIND once a revolution with count 0. */
static long spindle_count;
static avr_cycle_count_t spindle_edge(avr_t *a, avr_cycle_count_t when, void *param)
{
    (void)a;
    (void)param;
    static int high;
    pin_t iclk = {'D', 0}, sind = {'D', 1};
    if (high) {
        drive(iclk, 0);
        if (spindle_count % spindle_counts == 1)
            drive(sind, 0);
        high = 0;
        double period = 60.0 * avr->frequency / spindle_rpm / (double)spindle_counts;
        long next = (long)((double)(spindle_count + 1) * period) - (long)((double)spindle_count * period);
        return when + (avr_cycle_count_t)(next > 64 ? next - 32 : 32);
    }
    if (spindle_count % spindle_counts == 0)
        drive(sind, 1);
    drive(iclk, 1);
    spindle_count++;
    high = 1;
    return when + 32;
}

/* ---- the USART ------------------------------------------------------------------------- */

static uint8_t rx_fifo[RX_FIFO];
static size_t rx_head, rx_tail;
static int uart_xon = 1;
static int client = -1;
static int pipe_mode;                     /* --pipe: lockstep with the parent over stdin / stdout */
static unsigned long long run_until;
static int stop_at_flag, flag_sent;       /* "W CYCLE": stop early after a 0x7E sent */

static void uart_out(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    (void)param;
    uint8_t byte = (uint8_t)value;
    if (log_file)
        fprintf(log_file, "U %llu %02x\n", (unsigned long long)avr->cycle, byte);
    if (client >= 0 && send(client, &byte, 1, MSG_NOSIGNAL) < 0)
        client = -1;
    if (pipe_mode) {
        printf("U %llu %02x", (unsigned long long)avr->cycle, byte);
        for (int i = 0; i < n_axes; i++)
            printf(" %ld", axes[i].steps);
        printf("\n");
        flag_sent |= stop_at_flag && byte == 0x7E;
    }
}

static void uart_xon_cb(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq; (void)value; (void)param;
    uart_xon = 1;
}

static void uart_xoff_cb(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq; (void)value; (void)param;
    uart_xon = 0;
}

static avr_irq_t *uart_in;

static void uart_feed(void)
{
    avr_irq_t *in = uart_in;
    while (uart_xon && rx_tail != rx_head) {
        avr_raise_irq(in, rx_fifo[rx_tail]);
        rx_tail = (rx_tail + 1) % RX_FIFO;
    }
}

static void rx_push(const uint8_t *data, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        size_t next = (rx_head + 1) % RX_FIFO;
        if (next == rx_tail)
            return;
        rx_fifo[rx_head] = data[i];
        rx_head = next;
    }
}

/* ---- script and socket ------------------------------------------------------------------ */

typedef struct { unsigned long long cycle; uint8_t *bytes; size_t n; } chunk_t;
static chunk_t *script;
static size_t n_script, script_next;

static void read_script(const char *path)
{
    FILE *f = fopen(path, "r");
    if (!f) { fprintf(stderr, "hil: %s: %s\n", path, strerror(errno)); exit(2); }
    char *line = NULL;
    size_t cap = 0;
    while (getline(&line, &cap, f) > 0) {
        unsigned long long cycle;
        int used;
        if (sscanf(line, "%llu %n", &cycle, &used) < 1)
            continue;
        script = realloc(script, (n_script + 1) * sizeof *script);
        chunk_t *c = &script[n_script++];
        c->cycle = cycle;
        c->bytes = malloc(strlen(line) / 2 + 1);
        c->n = 0;
        for (char *p = line + used; p[0] && p[1] && p[0] != '\n'; p += 2) {
            unsigned v;
            if (sscanf(p, "%2x", &v) != 1)
                break;
            c->bytes[c->n++] = (uint8_t)v;
        }
    }
    free(line);
    fclose(f);
}

static int listener = -1;
static unsigned long long boot_cycles;    /* --boot-ms: bytes that arrive sooner are dropped */

static void open_listener(const char *spec)
{
    char host[128];
    int port;
    if (sscanf(spec, "%127[^:]:%d", host, &port) != 2) {
        fprintf(stderr, "hil: --listen %s: expected HOST:PORT\n", spec);
        exit(2);
    }
    struct sockaddr_in sa = {.sin_family = AF_INET, .sin_port = htons((uint16_t)port)};
    if (inet_pton(AF_INET, strcmp(host, "localhost") ? host : "127.0.0.1", &sa.sin_addr) != 1) {
        fprintf(stderr, "hil: --listen %s: not an IPv4 address\n", spec);
        exit(2);
    }
    listener = socket(AF_INET, SOCK_STREAM, 0);
    int one = 1;
    setsockopt(listener, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    if (bind(listener, (struct sockaddr *)&sa, sizeof sa) < 0 || listen(listener, 1) < 0) {
        fprintf(stderr, "hil: --listen %s: %s\n", spec, strerror(errno));
        exit(2);
    }
    socklen_t len = sizeof sa;
    getsockname(listener, (struct sockaddr *)&sa, &len);
    fcntl(listener, F_SETFL, O_NONBLOCK);
    printf("listening on %s:%d\n", host, ntohs(sa.sin_port));
    fflush(stdout);
}

/* Accept a client, read what it sent; 1 when the client hung up. */
static int poll_socket(void)
{
    if (client < 0) {
        client = accept(listener, NULL, NULL);
        if (client < 0)
            return 0;
        int one = 1;
        setsockopt(client, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
        fcntl(client, F_SETFL, O_NONBLOCK);
    }
    uint8_t buf[4096];
    ssize_t n = recv(client, buf, sizeof buf, 0);
    if (n > 0 && avr->cycle >= boot_cycles)
        rx_push(buf, (size_t)n);           /* before: a bootloader's time, the bytes are lost */
    if (n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK)) {
        close(client);
        client = -1;
        return 1;
    }
    return 0;
}

/* --pipe: at the cycle granted, say so and take the parent's bytes and the next grant. */
static void pipe_turn(void)
{
    static char *line;
    static size_t cap;
    printf("A %llu\n", (unsigned long long)avr->cycle);
    fflush(stdout);
    flag_sent = 0;
    for (int granted = 0; !granted;) {
        if (getline(&line, &cap, stdin) <= 0) {
            stop_now = 1;
            return;
        }
        if (line[0] == 'R' || line[0] == 'W') {
            run_until = strtoull(line + 1, NULL, 10);
            stop_at_flag = line[0] == 'W';
            granted = run_until > avr->cycle;
        }
        else if (line[0] == 'B')
            for (char *p = line + 2; p[0] && p[1] && p[0] != '\n'; p += 2) {
                unsigned v;
                if (sscanf(p, "%2x", &v) != 1)
                    break;
                uint8_t b = (uint8_t)v;
                if (avr->cycle >= boot_cycles)
                    rx_push(&b, 1);
            }
    }
}

/* ---- bootloader, glitches, a hung main loop ---------------------------------------------- */

#define MCUSR_ADDR 0x54                   /* ATmega2560: MCU status register (I/O 0x34) */
#define PORF 0x01
#define EXTRF 0x02

typedef struct { pin_t pin; unsigned long long at, cycles; int level, saved, state; } glitch_t;
static glitch_t glitches[MAX_SWITCHES];
static int n_glitches;
static unsigned long long stall_at;
static int stall_cli, stall_state;        /* 0 waiting, 1 stalled */

/* A loop of its own at the top of the flash, beyond any firmware: "cli; rjmp ." (the rjmp alone
 * keeps the interrupts on). Returns the byte address of the cli. */
static uint32_t plant_loop(void)
{
    uint32_t at = avr->flashend + 1 - 4;     /* the last two words */
    avr->flash[at] = 0xF8;                /* cli */
    avr->flash[at + 1] = 0x94;
    avr->flash[at + 2] = 0xFF;            /* rjmp . */
    avr->flash[at + 3] = 0xCF;
    return at;
}

/* Before the firmware: the bootloader's time (the CPU in its own loop, interrupts off). */
static void boot_start(void)
{
    if (boot_cycles) {
        avr->pc = plant_loop();
        avr->data[MCUSR_ADDR] = EXTRF;
    } else
        avr->data[MCUSR_ADDR] = PORF;
}

static int pin_input_level(pin_t p)
{
    int k = p.port - 'A';
    return (ext_mask[k] >> p.bit) & 1 ? (ext_value[k] >> p.bit) & 1 : 1;   /* else: pull-up */
}

/* Called before every instruction: the bootloader's end, glitches, the stall. */
static void events(void)
{
    unsigned long long now = avr->cycle;
    if (boot_cycles && now >= boot_cycles) {
        avr->pc = 0;                      /* the bootloader jumps to the firmware */
        boot_cycles = 0;
    }
    for (int i = 0; i < n_glitches; i++) {
        glitch_t *g = &glitches[i];
        if (g->state == 0 && now >= g->at) {
            g->saved = pin_input_level(g->pin);
            drive(g->pin, g->level);
            g->state = 1;
        } else if (g->state == 1 && now >= g->at + g->cycles) {
            drive(g->pin, g->saved);
            g->state = 2;
        }
    }
    if (stall_at && !stall_state && now >= stall_at && avr->interrupts.running_ptr == 0
        && avr->sreg[S_I]) {
        uint32_t loop = plant_loop();
        avr->pc = stall_cli ? loop : loop + 2;
        stall_state = 1;
        if (log_file)
            fprintf(log_file, "S %llu\n", now);
    }
}

/* ---- the harness's own events ------------------------------------------------------------ */

/* The harness's own next event after now (a grant's end, a script's bytes, a glitch's edge, the
 * stall, the bootloader's end, a socket poll, the run's end; ~0: none): now itself while the
 * stall waits for its moment. */
static unsigned long long next_event(unsigned long long next_poll, unsigned long long max_cycles)
{
    unsigned long long next = next_poll, now = avr->cycle;
#define SOONER(c) if ((c) > now && (c) < next) next = (c)
    if (pipe_mode)
        SOONER(run_until);
    if (script_next < n_script)
        SOONER(script[script_next].cycle);
    if (max_cycles)
        SOONER(max_cycles);
    if (boot_cycles)
        SOONER(boot_cycles);
    if (stall_at && !stall_state)
        SOONER(stall_at);
    for (int i = 0; i < n_glitches; i++)
        SOONER(glitches[i].state == 0 ? glitches[i].at : glitches[i].at + glitches[i].cycles);
#undef SOONER
    return stall_at && !stall_state && now >= stall_at ? now : next;
}

/* ---- interrupt figures ------------------------------------------------------------------ */

static int want_stats;
static unsigned long long off_start, off_longest_main, off_longest_isr, isr_cycles, isr_start;
static unsigned long long isr_longest, off_pc, off_main_pc, off_isr_pc, off_isr_end;
static int was_off, was_isr, last_ptr;
static unsigned long entries[64];          /* interrupts taken, by vector */

static void account(void)
{
    static int started;                  /* the firmware's first sei(): the boot does not count */
    int off = !avr->sreg[S_I];
    int in_isr = avr->interrupts.running_ptr > 0;
    unsigned long long now = avr->cycle;
    if (avr->interrupts.running_ptr > last_ptr && avr->interrupts.running_ptr <= 64)
        entries[avr->interrupts.running[avr->interrupts.running_ptr - 1]->vector & 63]++;
    last_ptr = avr->interrupts.running_ptr;
    if (!started) {
        if (off)
            return;
        started = 1;
    }
    if (in_isr != was_isr) {
        if (in_isr)
            isr_start = now;
        else {
            isr_cycles += now - isr_start;
            if (now - isr_start > isr_longest)
                isr_longest = now - isr_start;
        }
    }
    if (off != was_off) {
        if (off) {
            off_start = now;
            off_pc = avr->pc;
        } else if (was_isr || in_isr) {
            if (now - off_start > off_longest_isr) {
                off_longest_isr = now - off_start;
                off_isr_pc = off_pc;
                off_isr_end = avr->pc;
            }
        } else if (now - off_start > off_longest_main) {
            off_longest_main = now - off_start;
            off_main_pc = off_pc;
        }
    }
    was_off = off;
    was_isr = in_isr;
}

/* ---- main ------------------------------------------------------------------------------- */

static pin_t parse_pin(const char *s)
{
    pin_t p = {s[0], s[1] - '0'};
    if (p.port < 'A' || p.port > 'L' || p.bit < 0 || p.bit > 7) {
        fprintf(stderr, "hil: pin %s: expected a port letter and bit, e.g. F0\n", s);
        exit(2);
    }
    return p;
}

static void on_signal(int sig) { (void)sig; stop_now = 1; }

static double now_s(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + (double)t.tv_nsec * 1e-9;
}

int main(int argc, char **argv)
{
    const char *elf = NULL, *listen_at = NULL, *vcd_path = NULL;
    unsigned long long max_cycles = 0;
    double speed = -1.0;
    int once = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : "";
        if (!strcmp(a, "--listen")) { listen_at = v; i++; }
        else if (!strcmp(a, "--script")) { read_script(v); i++; }
        else if (!strcmp(a, "--log")) { log_file = fopen(v, "w"); i++; }
        else if (!strcmp(a, "--vcd")) { vcd_path = v; i++; }
        else if (!strcmp(a, "--cycles")) { max_cycles = strtoull(v, NULL, 10); i++; }
        else if (!strcmp(a, "--speed")) { speed = atof(v); i++; }
        else if (!strcmp(a, "--once")) once = 1;
        else if (!strcmp(a, "--pipe")) pipe_mode = 1;
        else if (!strcmp(a, "--no-port-log")) log_ports = 0;
        else if (!strcmp(a, "--boot-ms")) { boot_cycles = (unsigned long long)(atof(v) * 16000.0); i++; }
        else if (!strcmp(a, "--stats")) want_stats = 1;
        else if (!strcmp(a, "--stall")) {
            char how[8] = "";
            sscanf(v, "%llu,%7s", &stall_at, how);
            stall_cli = !strcmp(how, "cli");
            i++;
        } else if (!strcmp(a, "--glitch") && n_glitches < MAX_SWITCHES) {
            char p[4];
            glitch_t *g = &glitches[n_glitches++];
            if (sscanf(v, "%2s,%llu,%llu,%d", p, &g->at, &g->cycles, &g->level) != 4) {
                fprintf(stderr, "hil: --glitch %s: expected PIN,CYCLE,CYCLES,LEVEL\n", v);
                return 2;
            }
            g->pin = parse_pin(p);
            i++;
        }
        else if (!strcmp(a, "--axis") && n_axes < MAX_AXES) {
            char s[4], d[4];
            int inv = 0;
            long start = 0;
            sscanf(v, "%2s,%2s,%d,%ld", s, d, &inv, &start);
            axes[n_axes++] = (axis_t){parse_pin(s), parse_pin(d), inv, start, 0};
            i++;
        } else if (!strcmp(a, "--switch") && n_switches < MAX_SWITCHES) {
            char p[4], side;
            sw_t *w = &switches[n_switches++];
            sscanf(v, "%2s,%d,%c,%ld,%d", p, &w->axis, &side, &w->at, &w->active);
            w->pin = parse_pin(p);
            w->side = side;
            w->level = -1;
            i++;
        } else if (!strcmp(a, "--beam")) {
            char p[4];
            int got = sscanf(v, "%2[A-L0-7],%d,%d,%ld,%ld,%d,%ld,%ld,%d,%ld,%ld", p, &beam.level,
                             &beam.axis[0], &beam.lo[0], &beam.hi[0], &beam.axis[1], &beam.lo[1],
                             &beam.hi[1], &beam.axis[2], &beam.lo[2], &beam.hi[2]);
            beam.n = (got - 2) / 3;
            if (got < 2 || (got - 2) % 3) {
                fprintf(stderr, "hil: --beam %s: expected PIN,LEVEL then AXIS,LO,HI for 0 to 3 axes\n", v);
                return 2;
            }
            for (int k = 0; k < beam.n; k++)
                if (beam.axis[k] < 0 || beam.axis[k] >= MAX_AXES) {
                    fprintf(stderr, "hil: --beam %s: axis %d: expected 0..%d\n", v, beam.axis[k], MAX_AXES - 1);
                    return 2;
                }
            beam.pin = parse_pin(p);
            beam.used = 1;
            beam.state = -1;
            i++;
        } else if (!strcmp(a, "--seat")) {           /* X,LO,HI,Y,LO,HI,Z,LO,HI,CAROUSEL */
            const char *last = strrchr(v, ',');
            seat.used = parse_box(v, &seat) && last && sscanf(last + 1, "%d", &carousel_axis) == 1
                        && carousel_axis >= 0 && carousel_axis < MAX_AXES;
            if (!seat.used) {
                fprintf(stderr, "hil: --seat %s: expected X,LO,HI,Y,LO,HI,Z,LO,HI,CAROUSEL (axis numbers)\n", v);
                return 2;
            }
            i++;
        } else if (!strcmp(a, "--pocket")) {          /* N,LO,HI,TOOL: pocket N at the spindle */
            int n = 0, tool = 0;                      /* while the carousel is in LO..HI */
            long lo = 0, hi = -1;
            if (sscanf(v, "%d,%ld,%ld,%d", &n, &lo, &hi, &tool) != 4 || n < 1 || n >= MAX_TOOLS
                || tool < 0 || tool >= MAX_TOOLS) {
                fprintf(stderr, "hil: --pocket %s: expected N,LO,HI,TOOL with N 1..%d\n", v, MAX_TOOLS - 1);
                return 2;
            }
            pockets[n].lo = lo, pockets[n].hi = hi, pockets[n].tool = tool, pockets[n].used = 1;
            i++;
        } else if (!strcmp(a, "--tool-box")) {        /* T,X,LO,HI,Y,LO,HI,Z,LO,HI: where tool T */
            int t = 0, n = 0;                         /* breaks the beam */
            if (sscanf(v, "%d,%n", &t, &n) != 1 || t < 1 || t >= MAX_TOOLS || !parse_box(v + n, &tool_box[t])) {
                fprintf(stderr, "hil: --tool-box %s: expected T,X,LO,HI,Y,LO,HI,Z,LO,HI\n", v);
                return 2;
            }
            i++;
        } else if (!strcmp(a, "--spindle-tool")) {    /* the tool in the spindle at the start */
            spindle_tool = atoi(v);
            if (spindle_tool < 0 || spindle_tool >= MAX_TOOLS) {
                fprintf(stderr, "hil: --spindle-tool %s: expected 0..%d\n", v, MAX_TOOLS - 1);
                return 2;
            }
            i++;
        } else if (!strcmp(a, "--spindle-model")) {
            if (!spindle_model_args(v)) {
                fprintf(stderr, "hil: --spindle-model %s: expected COUNTS,MAX_RPM,TICK_CYCLES,RAMP_RPM,"
                        "TICK_S,NOISE_INTERVAL_TICKS,DRAWS_FILE (a file of doubles)\n", v);
                return 2;
            }
            i++;
        } else if (!strcmp(a, "--spindle-stall")) {
            sm.stalled = 1;
        } else if (!strcmp(a, "--spindle-stall-at")) {
            sm.stall_at = strtoull(v, NULL, 10);
            i++;
        } else if (!strcmp(a, "--spindle")) {
            sscanf(v, "%lf,%ld", &spindle_rpm, &spindle_counts);
            i++;
        } else if (a[0] != '-' && !elf) elf = a;
        else { fprintf(stderr, "hil: unknown option %s\n", a); return 2; }
    }
    if (!elf) { fprintf(stderr, "usage: hil FIRMWARE.elf [--listen HOST:PORT] [--script F] ...\n"); return 2; }
    elf_firmware_t fw;
    memset(&fw, 0, sizeof fw);
    if (elf_read_firmware(elf, &fw)) { fprintf(stderr, "hil: %s: cannot read the ELF\n", elf); return 2; }
    avr = avr_make_mcu_by_name("atmega2560");
    avr_init(avr);
    avr->log = 0;
    fw.frequency = 16000000;
    avr_load_firmware(avr, &fw);
    avr->frequency = 16000000;

    static const char ports[] = "ABCDFHKL";
    for (const char *p = ports; *p; p++)
        avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(*p), IOPORT_IRQ_PIN_ALL),
                                port_changed, (void *)(intptr_t)*p);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('B'), IOPORT_IRQ_PIN4),
                            pwm_pin_changed, NULL);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT), uart_out, NULL);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XON), uart_xon_cb, NULL);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF), uart_xoff_cb, NULL);
    /* The harness is not a terminal: no stdio on the USART's output. */
    uint32_t flags = 0;
    avr_ioctl(avr, AVR_IOCTL_UART_GET_FLAGS('0'), &flags);
    flags &= ~AVR_UART_FLAG_STDIO;
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
    /* A switch input held low would make simavr poll its INTn level trigger every cycle even
     * with the interrupt off (20x slower); the firmware uses edge triggers only. */
    for (uint8_t n = 0; n < 8; n++)
        avr_extint_set_strict_lvl_trig(avr, n, 0);
    uart_in = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
    update_switches();
    update_magazine();
    update_beam();
    boot_start();
    if (spindle_rpm > 0 && spindle_counts > 0)
        avr_cycle_timer_register(avr, 1000, spindle_edge, NULL);
    else if (sm.on) {
        avr_cycle_timer_register(avr, (avr_cycle_count_t)sm.tick_cycles, drive_tick, NULL);
        avr_cycle_timer_register(avr, PWM_WINDOW, pwm_window, NULL);
    }

    avr_vcd_t vcd;
    if (vcd_path) {
        avr_vcd_init(avr, vcd_path, &vcd, 1000);
        for (const char *p = ports; *p; p++) {
            char name[8] = {'P', 'O', 'R', 'T', *p, 0};
            avr_vcd_add_signal(&vcd, avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(*p), IOPORT_IRQ_PIN_ALL), 8, name);
        }
        avr_vcd_start(&vcd);
    }
    if (listen_at)
        open_listener(listen_at);
    if (speed < 0)
        speed = listen_at ? 1.0 : 0.0;
    signal(SIGTERM, on_signal);
    signal(SIGINT, on_signal);

    double wall0 = now_s();
    unsigned long long next_poll = 0;
    int state = cpu_Running;
    while (!stop_now && state != cpu_Done && state != cpu_Crashed) {
        if (max_cycles && avr->cycle >= max_cycles)
            break;
        if (pipe_mode && (avr->cycle >= run_until || flag_sent)) {
            pipe_turn();
            if (stop_now)
                break;
        }
        while (script_next < n_script && script[script_next].cycle <= avr->cycle) {
            rx_push(script[script_next].bytes, script[script_next].n);
            script_next++;
        }
        if (rx_tail != rx_head && (avr->data[UCSR0B_ADDR] & RXEN0_BIT))
            uart_feed();                      /* held until the firmware's receiver is on */
        if (avr->cycle >= next_poll) {
            next_poll = avr->cycle + 1600;            /* every 100 us of AVR time */
            if (listen_at && poll_socket() && once)
                break;
            if (speed > 0) {
                double ahead = (double)avr->cycle / avr->frequency / speed - (now_s() - wall0);
                if (ahead > 0.002)
                    usleep((useconds_t)(ahead * 1e6));
            }
        }
        events();
        unsigned long long next = next_event(listen_at || speed > 0 ? next_poll : ~0ULL, max_cycles);
        /* up to the harness's next event nothing above can happen but a frame's flag sent or a
         * signal: run the AVR in a tight loop (per instruction for --stats, and while bytes
         * wait for the receiver) */
        do {
            state = avr_run(avr);
            if (want_stats)
                account();
        } while (avr->cycle < next && !want_stats && rx_tail == rx_head && !flag_sent && !stop_now
                 && state != cpu_Done && state != cpu_Crashed);
    }
    if (vcd_path)
        avr_vcd_stop(&vcd);
    if (want_stats) {
        printf("stats cycles=%llu isr_cycles=%llu isr_longest=%llu off_main_longest=%llu "
               "off_isr_longest=%llu off_main_pc=%llu off_isr_pc=%llu off_isr_end=%llu", (unsigned long long)avr->cycle,
               isr_cycles, isr_longest, off_longest_main, off_longest_isr, off_main_pc, off_isr_pc, off_isr_end);
        for (int v = 0; v < 64; v++)          /* the interrupts taken, by vector number */
            if (entries[v])
                printf(" vector%d=%lu", v, entries[v]);
        printf("\n");
    }
    for (int i = 0; i < n_axes; i++)
        printf("axis %d steps=%ld\n", i, axes[i].steps);
    if (seat.used)
        printf("magazine spindle=%d\n", spindle_tool);
    printf("end cycles=%llu state=%d pc=%x\n", (unsigned long long)avr->cycle, state, avr->pc);
    if (log_file)
        fclose(log_file);
    return state == cpu_Crashed ? 3 : 0;
}
