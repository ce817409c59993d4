"""``python3 -m retrofit.cli``: the ``retrofit`` command."""

import os
import signal
import sys

from ..failsafe import ENDING

try:
    from . import main
    code = main()
except KeyboardInterrupt:                  # Ctrl-C while starting: nothing was written yet
    print("retrofit: interrupted; nothing was written", file=sys.stderr)
    code = 130
if code == 130 or code in (128 + sig for sig in ENDING):   # interrupted, stopped by a signal:
    # leave at once, without a second traceback
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except OSError:                    # SIGHUP: the terminal may be gone
            pass
    os._exit(code)
signal.signal(signal.SIGINT, signal.SIG_IGN)    # the work is done: a late Ctrl-C changes nothing
sys.exit(code)
