"""``python3 -m retrofit.cli``: the ``retrofit`` command."""

import os
import signal
import sys

try:
    from . import main
    code = main()
except KeyboardInterrupt:                  # Ctrl-C while starting: nothing was written yet
    print("retrofit: interrupted; nothing was written", file=sys.stderr)
    code = 130
if code == 130:                            # interrupted: leave at once, without a second traceback
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(130)
signal.signal(signal.SIGINT, signal.SIG_IGN)    # the work is done: a late Ctrl-C changes nothing
sys.exit(code)
