/* interp.c - 002's interpreter module and the processor's command-level state.
 *
 * 002: "interpreter is supplied from pipelined command queue, which could accept three commands
 * in advance ... if (processor.ispend()) goto interpret; processor.put(cmdq.getcmd())". The
 * processor here is the stepper's pending slot: a motion command is fetched and prepared as soon
 * as that slot is free, so the next move is ready when the running one ends. Set-up commands
 * (PFDR, CSTP, ISTP) take effect when fetched; commands that act on the machine at a point of
 * the program (PSTN, SPIN, COOL, DELY, ZMOV, PROB) wait until the motion before them has ended;
 * nothing after a PROB is fetched until it has ended.
 * The immediate commands (STOP, RDPS, RDST), INIT and the feed overrides FFDR and MFDR never
 * enter the queue (commands.c). */
#include "interp.h"
#include "opcodes.h"
#include "queue.h"
#include "io.h"
#include "link.h"
#include "planner.h"
#include "probe.h"
#include "segment.h"
#include "stepper.h"
#include "switches.h"

/* Status word bits (docs/protocol.md §8); the switch bits come from switches.c. */
#define ST_MOVING      0x0001
#define ST_QUEUE_FULL  0x0002
#define ST_HOMED       0x0080
#define ST_ERROR       0x0100
#define ST_INDEXER     0x0200
#define ST_STOPPED     0x0400
#define ST_DWELLING    0x0800
#define ST_SPINDLE_ON  0x1000
#define ST_COOLANT_ON  0x2000
#define ST_INDEX_SEEN  0x4000
#define ST_PROBED      0x8000
#define ST_HOST_LOST   0x10000UL       /* the heartbeat stopped the machine (docs/protocol.md §5) */
#define ST_STEP_ERROR  0x20000UL       /* a line ended with steps other than its own */

#define FEED_UNITS_PER_MM 10000.0f     /* feeds travel in 0.1 um per minute (or per rev) */

enum { HOME_IDLE, HOME_START, HOME_SEEKING, HOME_RELEASING, HOME_BACKING, HOME_LATCHING, HOME_DONE };
#define NO_SWITCH 255

static int32_t planned[N_AXES];        /* where the last prepared move ends: machine steps */
static int32_t offset[N_AXES];         /* PSTN: program coordinate = machine steps - offset */
static float fast_feed, machining_feed, program_feed;    /* mm/min (mm/rev under ISTP) */
static uint8_t program_feed_waiting;   /* PFDR: applies at the next motion command fetched */
static uint8_t indexer;                /* ISTP: the spindle encoder is the step source */
static float spindle_rpm;              /* SPIN's speed: the thread speed is checked against it */
static uint8_t thread_chain;           /* the last move prepared was an ISTP PMOV */
static uint32_t flags;                 /* HOMED, ERROR, STOPPED, SPINDLE_ON, COOLANT_ON, PROBED,
                                          HOST_LOST,
                                          STEP_ERROR (the position is not the plan's) */
static uint8_t dwelling;
static uint32_t dwell_left_ms;
static uint8_t home_order[N_AXES], home_count, home_index, home_phase;
static uint16_t index_wait_ms;         /* how long a thread pass has seen no SIND */

static const uint8_t default_home_order[N_AXES] = HOME_ORDER;
static const int8_t home_dir[N_AXES] = HOME_DIRS;              /* the seek switch's side */
static const uint8_t home_seek[N_AXES] = HOME_SEEK_SWITCH;
static const uint8_t home_ref[N_AXES] = HOME_REF_SWITCH;
static const int32_t home_steps[N_AXES] = HOME_STEPS;
static const uint32_t travel_steps[N_AXES] = TRAVEL_STEPS;
static const uint32_t backoff_steps[N_AXES] = HOME_BACKOFF_STEPS;
static const float latch_feed[N_AXES] = HOME_LATCH_MM_MIN;
static const int32_t min_steps[N_AXES] = MIN_STEPS;            /* soft limits, machine steps */
static const int32_t max_steps[N_AXES] = MAX_STEPS;

static void forget_motion(void)
{
    stepper_stop();
    planner_clear();
    segment_reset();
    queue_clear();
    dwelling = 0;
    segment_hold(0);
    home_phase = HOME_IDLE;
    thread_chain = 0;
    probe_cancel();
    stepper_position(planned);         /* prepare from where the axes really are, */
    planner_resync();                  /* and from the side each nut really rests on */
}

void interp_init(void)
{
    forget_motion();
    for (uint8_t i = 0; i < N_AXES; i++) {
        stepper_set_position(i, 0);
        planned[i] = offset[i] = 0;
    }
    fast_feed = RAPID_FEED_MM_MIN;
    machining_feed = program_feed = DEFAULT_FEED_MM_MIN;
    program_feed_waiting = 0;
    indexer = 0;
    flags &= ST_SPINDLE_ON | ST_COOLANT_ON;            /* INIT resets motion, not the spindle */
    stepper_clear_index_seen();
}

void interp_stop(void)
{
    forget_motion();
    flags |= ST_STOPPED;
}

static void fault(void)
{
    forget_motion();
    flags |= ST_ERROR;
}

/* Where a move to `c`'s position, taken now, ends: machine steps. */
static void target_of(const command_t *c, int32_t *target)
{
    for (uint8_t i = 0; i < N_AXES; i++)
        target[i] = (c->axes >> i) & 1 ? c->pos[i] + offset[i] : planned[i];
}

/* 1 if a move to `c`'s position, taken now, stays inside the soft limits. */
static uint8_t inside_limits(const command_t *c)
{
    int32_t target[N_AXES];
    target_of(c, target);
    for (uint8_t i = 0; i < N_AXES; i++)
        if (target[i] < min_steps[i] || target[i] > max_steps[i])
            return 0;
    return 1;
}

uint8_t interp_accepts(const command_t *cmd)
{
    if (flags & (ST_ERROR | ST_STOPPED))
        return 0;                      /* the operator or a switch stopped it: INIT first */
    if (cmd->op == OP_ISTP && ENCODER_COUNTS_PER_REV == 0)
        return 0;                      /* no spindle encoder on this machine */
    uint8_t bad = (cmd->op == OP_PFDR && cmd->value == 0) ||     /* a feed of 0: never ends */
                  (cmd->op == OP_PROB && PROBE_SWITCH == NO_SWITCH);   /* no probe input */
    if ((cmd->op == OP_FMOV || cmd->op == OP_PMOV || cmd->op == OP_PROB) && !bad && !home_phase &&
        !queue_holds(OP_PSTN) && !queue_holds(OP_ZMOV))
        bad = !inside_limits(cmd);     /* the coordinates it will have are known: check now */
    if (bad)
        fault();                       /* refused, and the controller is in ERROR until INIT */
    return !bad;
}

static uint8_t idle(void)
{
    return !stepper_busy() && planner_empty() && !segment_active() && !dwelling && !home_phase;
}

uint8_t interp_position_answer(uint8_t *answer)
{
    static const uint8_t bits[N_AXES] = AXIS_BITS;     /* ascending: the POS order */
    int32_t now[N_AXES];
    stepper_position(now);                             /* machine steps */
    uint8_t n = 2;
    answer[0] = ANS_POS;
    answer[1] = 0;
    for (uint8_t i = 0; i < N_AXES; i++) {
        answer[1] |= (uint8_t)(1 << bits[i]);
        int32_t steps = now[i] - offset[i];
        if (steps > 8388607L || steps < -8388607L) {   /* POS cannot carry it: ERR 3 */
            answer[0] = ANS_ERR;
            answer[1] = ERR_VALUE;
            answer[2] = OP_RDPS;
            return 3;
        }
        answer[n++] = (uint8_t)(steps >> 16);          /* signed 24-bit, big-endian */
        answer[n++] = (uint8_t)(steps >> 8);
        answer[n++] = (uint8_t)steps;
    }
    return n;
}

uint8_t interp_status_answer(uint8_t *answer)
{
    uint32_t s = flags | switch_status();
    if (!idle())
        s |= ST_MOVING;
    if (queue_count() == QUEUE_DEPTH)
        s |= ST_QUEUE_FULL;
    if (indexer)
        s |= ST_INDEXER;
    if (dwelling)
        s |= ST_DWELLING;
    if ((flags & ST_SPINDLE_ON) && stepper_index_seen())
        s |= ST_INDEX_SEEN;
    answer[0] = ANS_STAT;
    answer[1] = (uint8_t)(s >> 16);
    answer[2] = (uint8_t)(s >> 8);
    answer[3] = (uint8_t)s;
    answer[4] = queue_count();
    return 5;
}

/* ---- homing (ZMOV) ---------------------------------------------------------------------
 * For each axis in order: seek its limit switch at the fast feed (FFDR), back away slowly until
 * it opens and then backoff_mm more, creep onto the reference (precise-position) switch at the
 * latch feed, and take the home position there. An axis without a homing switch moves fast to
 * its home position instead. A switch that is not found within the travel is an ERROR. */

static void homing_step(uint8_t events)
{
    move_t m;
    uint8_t axis = home_order[home_index];
    uint8_t seek = home_seek[axis], ref = home_ref[axis];
    int8_t dir = home_dir[axis];
    uint32_t near = travel_steps[axis] / 8;            /* how far a slow homing move may go */
    if (home_phase != HOME_START && !(events & EV_DONE))
        return;                                        /* the homing move still runs */
    if ((home_phase == HOME_SEEKING || home_phase == HOME_RELEASING ||
         home_phase == HOME_LATCHING) && !(events & EV_SWITCH)) {
        fault();                                       /* the switch did not close / open */
        return;
    }
    switch (home_phase) {
    case HOME_START:
        if (seek == NO_SWITCH) {                       /* no switch: a fast move home */
            int32_t to[N_AXES];
            for (uint8_t i = 0; i < N_AXES; i++)
                to[i] = i == axis ? home_steps[axis] : planned[i];
            home_phase = HOME_DONE;
            if (!plan_line(&m, planned, to, FEED_FAST, fast_feed, 0))
                return;
            break;
        }
        plan_home(&m, axis, dir, travel_steps[axis], MOVE_SEEK, seek, FEED_FAST, fast_feed);
        home_phase = HOME_SEEKING;
        break;
    case HOME_SEEKING:
        plan_home(&m, axis, (int8_t)-dir, near, MOVE_RELEASE, seek, FEED_HOMING, latch_feed[axis]);
        home_phase = HOME_RELEASING;
        break;
    case HOME_RELEASING:
        home_phase = HOME_BACKING;
        if (backoff_steps[axis]) {
            plan_home(&m, axis, (int8_t)-dir, backoff_steps[axis], MOVE_LINE, seek, FEED_HOMING,
                      latch_feed[axis]);
            break;
        }
        /* fall through: no back-off distance */
    case HOME_BACKING:
        plan_home(&m, axis, dir, near, MOVE_SEEK, ref, FEED_HOMING, latch_feed[axis]);
        home_phase = HOME_LATCHING;
        break;
    default:                                           /* LATCHING or DONE: machine zero */
        stepper_set_position(axis, home_steps[axis]);
        planned[axis] = home_steps[axis];
        offset[axis] = 0;                              /* machine zero: coordinates reset */
        home_phase = ++home_index < home_count ? HOME_START : HOME_IDLE;
        if (home_phase == HOME_IDLE)
            flags |= ST_HOMED;
        return;
    }
    planner_submit(&m);
}

static void start_homing(const command_t *c)
{
    home_count = c->n_order ? c->n_order : HOME_COUNT;
    for (uint8_t i = 0; i < home_count; i++)
        home_order[i] = c->n_order ? c->order[i] : default_home_order[i];
    home_index = 0;
    home_phase = home_count ? HOME_START : HOME_IDLE;
    if (!home_count)
        flags |= ST_HOMED;
}

/* ---- fetch ---------------------------------------------------------------------------- */

static void fetch_motion(const command_t *c)
{
    int32_t target[N_AXES];
    move_t m;
    uint8_t fast = c->op == OP_FMOV;
    if (!inside_limits(c)) {
        fault();                                       /* outside the soft limits */
        return;
    }
    target_of(c, target);
    uint8_t synchronised = !fast && indexer;
    if (plan_line(&m, planned, target, fast ? FEED_FAST : FEED_MACHINING,
                  fast ? fast_feed : machining_feed, synchronised)) {
        m.chained = synchronised && thread_chain;      /* the next pass of the same thread */
        if (!plan_thread(&m, spindle_rpm)) {
            fault();                                   /* refused before any motion */
            return;
        }
        thread_chain = synchronised;
        planner_submit(&m);
        for (uint8_t i = 0; i < N_AXES; i++)
            planned[i] = target[i];
    }
}

/* PROB, at rest (probe.c); only the clock may step it (CSTP). */
static void fetch_probe(const command_t *c)
{
    int32_t target[N_AXES];
    flags &= ~ST_PROBED;
    if (indexer || !inside_limits(c)) {
        fault();                                       /* under ISTP, or beyond the soft limits */
        return;
    }
    target_of(c, target);
    uint8_t r = probe_start(planned, target, c->value & PROB_UNTIL_OPEN, machining_feed);
    if (r == PROBE_FOUND)
        flags |= ST_PROBED;
    for (uint8_t i = 0; r == PROBE_RUNNING && i < N_AXES; i++)
        planned[i] = target[i];
}

static void fetch_at_rest(const command_t *c)
{
    thread_chain = 0;                                  /* a pause: the next pass waits for SIND */
    switch (c->op) {
    case OP_DELY:
        dwell_left_ms = c->value;
        dwelling = dwell_left_ms != 0;
        segment_hold(dwelling);                        /* the next move waits for the dwell */
        break;
    case OP_ZMOV:
        start_homing(c);
        break;
    case OP_PSTN:
        for (uint8_t i = 0; i < N_AXES; i++)
            if ((c->axes >> i) & 1)
                offset[i] = planned[i] - c->pos[i];    /* the axis now reads c->pos[i] */
        break;
    case OP_SPIN: {
        int8_t direction = (int8_t)(c->value & 0xFF);
        if (direction && !(flags & ST_SPINDLE_ON))
            stepper_clear_index_seen();                /* INDEX_SEEN: since the spindle started */
        spindle_set((uint16_t)(c->value >> 8), direction);
        spindle_rpm = direction ? (float)(c->value >> 8) : 0.0f;
        flags = direction ? flags | ST_SPINDLE_ON : flags & ~ST_SPINDLE_ON;
        break;
    }
    case OP_COOL:
        coolant_set((uint8_t)c->value);
        flags = c->value ? flags | ST_COOLANT_ON : flags & ~ST_COOLANT_ON;
        break;
    case OP_PROB:
        fetch_probe(c);
        break;
    }
}

/* Set-up commands: effective when fetched. */
static void fetch_setup(const command_t *c)
{
    switch (c->op) {
    case OP_PFDR:
        program_feed = (float)c->value / FEED_UNITS_PER_MM;
        program_feed_waiting = 1;                      /* at the next motion command */
        break;
    case OP_CSTP:
        indexer = thread_chain = 0;
        break;
    case OP_ISTP:
        indexer = 1;
        break;
    }
}

void interp_override(const command_t *c)
{
    float feed = (float)c->value / FEED_UNITS_PER_MM;
    if (c->op == OP_FFDR) {
        fast_feed = feed;
        planner_set_feed(FEED_FAST, feed);             /* even mid-move */
    } else {
        machining_feed = feed;
        program_feed_waiting = 0;                      /* the operator's feed wins */
        planner_set_feed(FEED_MACHINING, feed);
    }
}

void interp_run(void)
{
    segment_prepare();                                 /* keep the step interrupt fed */
    uint8_t events = stepper_take_events();
    if (probe_running() && idle())                     /* a stop on the probe that came since: */
        events |= stepper_take_events();               /* at rest, no other can come */
    if (events & (EV_LIMIT | EV_STEPS)) {
        if (events & EV_STEPS)
            flags |= ST_STEP_ERROR;                    /* a line's steps were not its own */
        fault();
        return;
    }
    if (events & EV_SWITCH) {                          /* a homing or probing move ended on */
        stepper_stop();                                /* its switch: the rest of it is dropped */
        planner_clear();
        segment_reset();
    }
    if (probe_running()) {
        if (probe_update(events, idle(), planned) == PROBE_FOUND)
            flags |= ST_PROBED;
        if (probe_running())
            return;                                    /* nothing is fetched behind a PROB */
    }
    if (home_phase) {
        homing_step(events);
        return;
    }
    if (!queue_count())
        return;
    command_t *c = queue_head();
    uint8_t op = c->op;
    uint8_t motion = op == OP_FMOV || op == OP_PMOV;
    uint8_t at_rest = op == OP_DELY || op == OP_ZMOV || op == OP_PSTN || op == OP_SPIN ||
                      op == OP_COOL || op == OP_PROB;
    if ((motion && planner_room() < 2) || (at_rest && !idle()))
        return;                                        /* the processor cannot take it yet */
    if ((motion || op == OP_DELY || op == OP_ZMOV || op == OP_PROB) && program_feed_waiting) {
        machining_feed = program_feed;
        program_feed_waiting = 0;
    }
    command_t cmd = *c;                                /* fetched: its slot is free again */
    queue_pop();
    if (motion)
        fetch_motion(&cmd);
    else if (at_rest)
        fetch_at_rest(&cmd);
    else
        fetch_setup(&cmd);
}

/* ---- the heartbeat's stop (heartbeat.c, docs/protocol.md §5.1) ---------------------------- */

uint8_t interp_has_work(void) { return !idle() || queue_count(); }

uint8_t interp_host_lost(void) { return (flags & ST_HOST_LOST) != 0; }

void interp_brake(float crawl_mm_min)
{
    queue_clear();                                     /* nothing more is fetched */
    home_phase = HOME_IDLE;
    planner_set_feed(FEED_FAST, crawl_mm_min);         /* every planned move slows down */
    planner_set_feed(FEED_MACHINING, crawl_mm_min);
    planner_set_feed(FEED_HOMING, crawl_mm_min);
    flags |= ST_HOST_LOST | ST_STOPPED;                /* motion refused until INIT */
}

void interp_halt_outputs(void)
{
    forget_motion();
    spindle_set(0, 0);
    coolant_set(0);
    spindle_rpm = 0.0f;
    flags &= ~(uint32_t)(ST_SPINDLE_ON | ST_COOLANT_ON);
}

void interp_tick_1ms(void)
{
    if (dwelling && --dwell_left_ms == 0) {
        dwelling = 0;
        segment_hold(0);
    }
    stepper_fold();
    led_set(!idle());
    if (!stepper_index_quiet())        /* an ISTP line without SIND: waiting, or the spindle */
        index_wait_ms = 0;             /* stopped during the pass */
    else if (++index_wait_ms >= INDEX_TIMEOUT_MS) {
        fault();                       /* no index pulse: the spindle is not turning */
        stepper_clear_index_seen();    /* ERROR, SPINDLE_ON, no INDEX_SEEN (protocol.md) */
    }
}
