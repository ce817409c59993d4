"""The machine description: machine files read from TOML, motors, the tool table and the spare I/O pins."""
