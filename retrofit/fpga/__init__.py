"""004's FPGA in Amaranth HDL: the pulse engine, its digital-integration variant, the host's
pulse records, the simulation harness and the build for an iCE40 board (one concept, one place)."""
