"""The run of a part program: program → plan → execute → outputs, its digital outputs, trace, progress, plots and report."""
