"""The firmware's host side: the compiled firmware in simavr, its measured rates, its stress run, and the Python device behind `retrofit mcu`."""
