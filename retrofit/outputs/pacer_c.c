/* The paced port writer in C: each byte written at its tick boundary, lateness recorded.
 *
 * Built by retrofit/outputs/pacer_build.py with the system C compiler the first time a port is
 * paced, and called through ctypes, which releases the Python GIL for the whole run. Besides
 * retrofit/outputs/pacer.py this is the only code of retrofit that reads the clock or sleeps.
 *
 * For each write i: due = t0 + ticks[i] * tick_ns on CLOCK_MONOTONIC (the clock of Python's
 * time.perf_counter_ns on Linux). The loop sleeps until spin_ns before the boundary when the wait
 * is longer than that (spin_ns < 0: never sleeps), busy-waits the rest, writes values[i], and
 * stores the lateness (clock after the write returned minus due) in late_ns[i]. A late byte is
 * written, never skipped. The byte goes to a ppdev port (ioctl PPWDATA on fd) when fd >= 0,
 * else into out[i] (a recording, or nothing at all for a trial). During the loop the thread's
 * timer slack is 1 ns (normally 50 us, which would make every sleep that much late).
 */

#define _GNU_SOURCE
#include <errno.h>
#include <stdint.h>
#include <time.h>
#include <sys/ioctl.h>
#include <sys/prctl.h>
#include <linux/ppdev.h>

int64_t retrofit_now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000000000LL + ts.tv_nsec;
}

static void sleep_until_ns(int64_t when)
{
    struct timespec ts = { (time_t)(when / 1000000000LL), (long)(when % 1000000000LL) };
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL) == EINTR)
        ;
}

/* Returns the number of bytes written (n), or -(1 + i) when the port refused write i
 * (errno is then kept for the caller). */
int64_t retrofit_pace(const int64_t *ticks, const uint8_t *values, int64_t n,
                      int64_t t0_ns, int64_t tick_ns, int64_t spin_ns, int paced,
                      int fd, uint8_t *out, int64_t *late_ns)
{
    int slack = prctl(PR_GET_TIMERSLACK, 0, 0, 0, 0);
    int64_t written = n;
    prctl(PR_SET_TIMERSLACK, 1, 0, 0, 0);
    for (int64_t i = 0; i < n; i++) {
        int64_t due = t0_ns + ticks[i] * tick_ns;
        if (paced) {
            if (spin_ns >= 0 && due - retrofit_now_ns() > spin_ns)
                sleep_until_ns(due - spin_ns);
            while (retrofit_now_ns() < due)
                ;
        }
        if (fd >= 0) {
            unsigned char byte = values[i];
            if (ioctl(fd, PPWDATA, &byte) != 0) {
                written = -(1 + i);
                break;
            }
        } else {
            out[i] = values[i];
        }
        late_ns[i] = paced ? retrofit_now_ns() - due : 0;
    }
    if (slack > 0) {
        int err = errno;
        prctl(PR_SET_TIMERSLACK, slack, 0, 0, 0);
        errno = err;
    }
    return written;
}
