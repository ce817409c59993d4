/* mitic-lathe.h - the settings of retrofit/machines/mitic-lathe.toml the firmware compiles in.
 * Written by firmware/tools/machine_header.py (make machine MACHINE=mitic-lathe);
 * edit the machine file, not this header: a test checks that they agree. */
#define MACHINE_NAME        "mitic-lathe"
#define N_AXES              2
#define AXIS_LETTERS        "XZ"
#define AXIS_BITS           { 0, 2 }   /* link mask bit of each axis */
#define FOR_EACH_AXIS(M)   M(0, X) M(1, Z)   /* index, RAMPS socket */
#define DIR_INVERT          0x00
#define STEPS_PER_MM        { 100.0f, 80.0f }
#define MAX_RATE_STEPS_S    { 2500.0f, 3200.0f }
#define ACCEL_STEPS_S2      { 30000.0f, 32000.0f }
#define BACKLASH_STEPS      { 2, 2 }
#define MIN_STEPS           { -4000, -16000 }   /* soft limits */
#define MAX_STEPS           { 4000, 1600 }
#define TRAVEL_STEPS        { 9351, 19801 }   /* the longest homing seek */
#define PULSE_HIGH_US       100   /* 'dunu': the step pulse */
#define MIN_PERIOD_US       200   /* 'perioada': the shortest step period */
#define DIR_SETUP_US        100
#define RAPID_FEED_MM_MIN   1500.0f
#define DEFAULT_FEED_MM_MIN 100.0f
#define JUNCTION_DEVIATION_MM 0.01f
#define ENCODER_COUNTS_PER_REV 400
#define SPINDLE_MAX_RPM     2000UL
#define SPINDLE_SPEED_TOLERANCE 0.15f   /* a thread is planned for a spindle this much faster */
#define SYNC_ACCEL_SHARE    0.8f   /* of the acceleration, for a thread's lead-in */
#define INDEX_TIMEOUT_MS    5000UL   /* a thread pass without an index pulse this long: ERROR */
/* SWITCH(id, axis, side, kind, RAMPS endstop connector, status bit or -1) */
#define SWITCHES \
    SWITCH(0, 0, -1, SW_LIMIT, XMIN, 2)   /* NLSX */ \
    SWITCH(1, 0, +1, SW_LIMIT, XMAX, 3)   /* PLSX */ \
    SWITCH(2, 1, +1, SW_LIMIT, ZMAX, 4)   /* PLSZ */ \
    SWITCH(3, 0, +1, SW_PRECISE, YMIN, 5)   /* PPSX */ \
    SWITCH(4, 1, +1, SW_PRECISE, YMAX, 6)   /* PPSZ */ \

#define N_SWITCHES          5
#define PROBE_SWITCH        255   /* PROB watches it; 255: no probe input */
#define HOME_COUNT          2
#define HOME_ORDER          { 0, 1 }
#define HOME_DIRS           { 1, 1 }
#define HOME_SEEK_SWITCH    { 1, 2 }   /* 255: the axis is not homed */
#define HOME_REF_SWITCH     { 3, 4 }
#define HOME_STEPS          { 4000, 1600 }   /* the position at the reference switch */
#define HOME_BACKOFF_STEPS  { 100, 80 }
#define HOME_LATCH_MM_MIN   { 30.0f, 30.0f }
