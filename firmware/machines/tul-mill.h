/* tul-mill.h - the settings of retrofit/machines/tul-mill.toml the firmware compiles in.
 * Written by firmware/tools/machine_header.py (make machine MACHINE=tul-mill);
 * edit the machine file, not this header: a test checks that they agree. */
#define MACHINE_NAME        "tul-mill"
#define N_AXES              4
#define AXIS_LETTERS        "XYZE"
#define AXIS_BITS           { 0, 1, 2, 7 }   /* link mask bit of each axis */
#define FOR_EACH_AXIS(M)   M(0, X) M(1, Y) M(2, Z) M(3, E0)   /* index, RAMPS socket */
#define DIR_INVERT          0x00
#define STEPS_PER_MM        { 100.0f, 100.0f, 100.0f, 160.0f }
#define MAX_RATE_STEPS_S    { 5000.0f, 5000.0f, 5000.0f, 8000.0f }
#define ACCEL_STEPS_S2      { 100000.0f, 100000.0f, 100000.0f, 160000.0f }
#define BACKLASH_STEPS      { 0, 0, 0, 0 }
#define MIN_STEPS           { 0, 0, -4500, 0 }   /* soft limits */
#define MAX_STEPS           { 4500, 4500, 0, 2560 }
#define TRAVEL_STEPS        { 5501, 5501, 5501, 3696 }   /* the longest homing seek */
#define PULSE_HIGH_US       10   /* 'dunu': the step pulse */
#define MIN_PERIOD_US       20   /* 'perioada': the shortest step period */
#define DIR_SETUP_US        10
#define RAPID_FEED_MM_MIN   3000.0f
#define DEFAULT_FEED_MM_MIN 300.0f
#define JUNCTION_DEVIATION_MM 0.01f
#define ENCODER_COUNTS_PER_REV 0
#define SPINDLE_MAX_RPM     3000UL
#define SPINDLE_SPEED_TOLERANCE 0.0f   /* a thread is planned for a spindle this much faster */
#define SYNC_ACCEL_SHARE    1.0f   /* of the acceleration, for a thread's lead-in */
#define INDEX_TIMEOUT_MS    5000UL   /* a thread pass without an index pulse this long: ERROR */
/* SWITCH(id, axis, side, kind, RAMPS endstop connector, status bit or -1) */
#define SWITCHES \
    SWITCH(0, 0, -1, SW_HOME, XMIN, -1)   /* XMIN */ \
    SWITCH(1, 1, -1, SW_HOME, XMAX, -1)   /* YMIN */ \
    SWITCH(2, 2, +1, SW_HOME, YMIN, -1)   /* ZTOP */ \
    SWITCH(3, 3, -1, SW_HOME, YMAX, -1)   /* CAROUSEL */ \
    SWITCH(4, 0, +1, SW_PROBE, ZMIN, -1)   /* the tool setter's beam (no axis) */ \

#define N_SWITCHES          5
#define PROBE_SWITCH        4   /* PROB watches it; 255: no probe input */
#define HOME_COUNT          4
#define HOME_ORDER          { 2, 1, 0, 3 }
#define HOME_DIRS           { -1, -1, 1, -1 }
#define HOME_SEEK_SWITCH    { 0, 1, 2, 3 }   /* 255: the axis is not homed */
#define HOME_REF_SWITCH     { 0, 1, 2, 3 }
#define HOME_STEPS          { 0, 0, 0, 0 }   /* the position at the reference switch */
#define HOME_BACKOFF_STEPS  { 100, 100, 100, 160 }
#define HOME_LATCH_MM_MIN   { 30.0f, 30.0f, 30.0f, 30.0f }
