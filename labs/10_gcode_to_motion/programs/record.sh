#!/bin/sh
# Re-record the expected moves of every program with LinuxCNC's own interpreter (Debian package
# linuxcnc-uspace, /usr/bin/rs274): its canonical machining calls, the moves and feeds only.
cd "$(dirname "$0")"
for f in *.ngc; do
    rs274 -g "$f" 2>&1 | grep -E "STRAIGHT_|SET_FEED_RATE" > "${f%.ngc}.canon"
done
