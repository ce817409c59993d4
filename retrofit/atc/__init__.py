"""The mill of 000: carousel tool changer, optical tool setter, tool table, and their simulator."""
