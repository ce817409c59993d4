"""Motion: pure, deterministic algorithms in integer ticks and steps (no I/O)."""
