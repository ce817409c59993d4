"""Klipper's host in batch mode on one G-code file, with its CPU split out (run by square_circle.py).

    KLIPPER_PYTHON klipper_batch.py KLIPPER_DIR printer.cfg file.gcode out.bin klipper.dict
    KLIPPER_PYTHON klipper_batch.py --count KLIPPER_DIR out.bin klipper.dict

Runs ``klippy.py printer.cfg -i file.gcode -o out.bin -d klipper.dict`` inside this process and
prints one JSON line with the CPU seconds spent inside Klipper's C step generation
(``steppersyncmgr_gen_steps``: iterative solver, step compression and queueing, all its
threads); the caller measures the whole process. ``--count`` prints the steps an output file
commands (``queue_step`` counts summed). Batch mode may stop its serial queue's thread at exit
before the last messages are written, so the file can hold fewer steps than were generated.
"""

import os

os.environ.setdefault("RETROFIT_READ_AHEAD", "1")     # the pipeline read ahead, window by window
import json
import sys
import time


def timed_step_generation(acc):
    """Wrap the motion queue's C step generation call so its CPU time adds up in ``acc``."""
    import extras.motion_queuing as mq
    original_init = mq.PrinterMotionQueuing.__init__

    def init(self, config):
        original_init(self, config)
        gen_steps = self.steppersyncmgr_gen_steps

        def timed(*args):
            start = time.process_time()
            try:
                return gen_steps(*args)
            finally:
                acc[0] += time.process_time() - start
        self.steppersyncmgr_gen_steps = timed
    mq.PrinterMotionQueuing.__init__ = init


def commanded_steps(dict_path, out_path):
    """Steps the batch output commands: the ``count`` of every ``queue_step`` message."""
    import msgproto
    parser = msgproto.MessageParser()
    with open(dict_path, "rb") as fh:
        parser.process_identify(fh.read(), decompress=False)
    with open(out_path, "rb") as fh:
        data = bytearray(fh.read())
    steps = 0
    while data:
        size = parser.check_packet(data)
        if size == 0:
            break
        if size < 0:
            data = data[-size:]
            continue
        for msg in parser.dump(data[:size])[1:]:
            if msg.startswith("queue_step "):
                steps += int(msg.split("count=")[1].split()[0])
        data = data[size:]
    return steps


def main():
    if sys.argv[1] == "--count":
        kdir, out, dictionary = sys.argv[2:5]
        sys.path.insert(0, os.path.join(kdir, "klippy"))
        print(commanded_steps(dictionary, out))
        return
    kdir, cfg, gcode, out, dictionary = sys.argv[1:6]
    sys.path.insert(0, os.path.join(kdir, "klippy"))
    acc = [0.0]
    timed_step_generation(acc)
    import klippy
    sys.argv = ["klippy.py", cfg, "-i", gcode, "-o", out, "-d", dictionary, "-l", out + ".log"]
    try:
        klippy.main()
    except SystemExit as exc:
        if exc.code:
            raise
    print(json.dumps({"gen_cpu": acc[0]}))


if __name__ == "__main__":
    main()
