"""Strict, typed reading of TOML tables: every key read once, every error names file, section, key."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path
from typing import Any

from ..errors import ConfigError

_MISSING = object()
#: the largest magnitude a number read from a file may have unless its getter sets its own range:
#: every quantity of a machine (mm, mm/s, ms, Hz, rpm ...) is far below it, and anything below it
#: stays finite when turned into ticks or steps
MAGNITUDE = 1e9
#: the smallest magnitude a non-zero number may have: below it a quotient (a time over a tick, a
#: distance over a speed) would overflow
TINY = 1e-9

#: how alike a key must be to one the section reads (difflib's ratio) to be called a misspelling of it
TYPO_RATIO = 0.75

_BOMS = ((b"\xff\xfe", "UTF-16"), (b"\xfe\xff", "UTF-16"), (b"\xef\xbb\xbf", "UTF-8 with a BOM"))


def shown_key(key: str) -> str:
    """A key as an error line shows it: as written if it is plain, quoted if it has spaces,
    control characters or nothing at all (so an error stays one readable line)."""
    return key if key and key.isprintable() and not any(c.isspace() for c in key) else repr(key)


def load_toml(path: Path) -> dict:
    """Parse a TOML file, turning every reading or syntax problem into a one-line ConfigError."""
    try:
        raw = Path(path).read_bytes()
    except FileNotFoundError:
        raise ConfigError(f"{path}: no such machine file") from None
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read it ({exc.strerror or exc}); expected a readable "
                          "TOML file") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        found = next((name for bom, name in _BOMS if raw.startswith(bom)), None)
        what = f"it is {found}" if found else f"byte 0x{raw[exc.start]:02x} at offset {exc.start}"
        raise ConfigError(f"{path}: not UTF-8 text ({what}); TOML files are UTF-8: save it as "
                          "UTF-8") from None
    if text.startswith("\ufeff"):
        text = text[1:]                     # a UTF-8 byte-order mark is harmless: skip it
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: not valid TOML: {exc}") from None
    except RecursionError:
        raise ConfigError(f"{path}: not valid TOML: nested too deeply") from None


class Section:
    """One TOML table read strictly: typed getters with ranges, and a check for keys nobody read.

    Klipper's habit: an option that nothing reads is a typo, so it is an error.
    """

    def __init__(self, file: str, name: str, data: dict):
        self.file, self.name, self._data = file, name, data
        self._read: set[str] = set()

    # -- errors -----------------------------------------------------------------------------
    def error(self, key: str, message: str) -> ConfigError:
        """A ConfigError worded `file [section] key = value: message`."""
        value = self._data.get(key, None)
        shown = "" if value is None or isinstance(value, dict) else f" = {value!r}"
        return ConfigError(f"{self.file} [{self.name}] {shown_key(key)}{shown}: {message}")

    # -- getters ----------------------------------------------------------------------------
    def has(self, key: str) -> bool:
        return key in self._data

    def _raw(self, key: str, default: Any, why: str | None = None) -> Any:
        """The value of ``key``; a missing required key is named with ``why`` it is needed, or
        the misspelt key that stands for it."""
        self._read.add(key)
        if key in self._data:
            return self._data[key]
        if default is _MISSING:
            import difflib
            typo = difflib.get_close_matches(key, [k for k in self._data if k not in self._read], 1, TYPO_RATIO)
            if typo:
                raise ConfigError(f"{self.file} [{self.name}] {shown_key(typo[0])}: unknown key "
                                  f"(did you mean {key}?)")
            where = f"[{self.name}] {key}" if self.name else f"[{key}]"
            raise ConfigError(f"{self.file} {where}: missing; {why or 'it is required'}")
        return default

    def get_float(self, key: str, default: Any = _MISSING, *, minval: float | None = None,
                  maxval: float | None = None, above: float | None = None) -> float:
        value = self._raw(key, default)
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.error(key, f"must be a number, not {type(value).__name__}")
        try:
            value = float(value)
        except OverflowError:               # a TOML integer too large for a float
            value = math.inf
        if not math.isfinite(value):
            raise self.error(key, "must be a finite number")
        self._check_range(key, value, minval, maxval, above)
        self._check_magnitude(key, value, minval, maxval)
        return value

    def get_int(self, key: str, default: Any = _MISSING, *, minval: int | None = None,
                maxval: int | None = None, why: str | None = None) -> int:
        value = self._raw(key, default, why)
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.error(key, f"must be a whole number, not {type(value).__name__}")
        self._check_range(key, value, minval, maxval, None)
        self._check_magnitude(key, value, minval, maxval)
        return value

    def get_bool(self, key: str, default: Any = _MISSING) -> bool:
        value = self._raw(key, default)
        if not isinstance(value, bool):
            raise self.error(key, "must be true or false")
        return value

    def get_str(self, key: str, default: Any = _MISSING, *, choices: tuple[str, ...] | None = None) -> str:
        value = self._raw(key, default)
        if not isinstance(value, str):
            raise self.error(key, f"must be a string, not {type(value).__name__}")
        if choices is not None and value not in choices:
            raise self.error(key, f"must be one of {', '.join(choices)}")
        return value

    def get_list(self, key: str, default: Any = _MISSING) -> list:
        value = self._raw(key, default)
        if not isinstance(value, list):
            raise self.error(key, f"must be a list, not {type(value).__name__}")
        return value

    def section(self, key: str, *, required: bool = True) -> Section | None:
        """A sub-table as a Section of its own (checked separately)."""
        value = self._raw(key, _MISSING if required else None)
        if value is None:
            return None
        if not isinstance(value, dict):
            raise self.error(key, "must be a table")
        shown = shown_key(key)
        return Section(self.file, f"{self.name}.{shown}" if self.name else shown, value)

    def subsections(self) -> list[tuple[str, Section]]:
        """Every key of this table as a sub-section, in file order."""
        return [(key, self.section(key)) for key in list(self._data)]

    def finish(self) -> None:
        """Refuse keys nothing read (typos)."""
        unread = [k for k in self._data if k not in self._read]
        if unread:
            key = unread[0]
            import difflib
            typo = difflib.get_close_matches(key, sorted(self._read), 1, TYPO_RATIO)
            where = f"{self.file} [{self.name}] {shown_key(key)}: unknown key"
            if typo:
                raise ConfigError(f"{where} (did you mean {typo[0]}?)")
            raise ConfigError(f"{where}; known keys here: {', '.join(sorted(self._read)) or 'none'}")

    def _check_magnitude(self, key, value, minval, maxval) -> None:
        """Without a range of its own, a number stays within +-MAGNITUDE; none is tinier than TINY."""
        if maxval is None and value > MAGNITUDE or minval is None and value < -MAGNITUDE:
            raise self.error(key, f"must be within +-{MAGNITUDE:g} (larger values cannot be "
                                  "turned into ticks or steps)")
        if value != 0 and abs(value) < TINY:
            raise self.error(key, f"must be 0 or at least {TINY:g} in size (smaller values "
                                  "overflow when divided by)")

    def _check_range(self, key, value, minval, maxval, above) -> None:
        if above is not None and not value > above:
            raise self.error(key, f"must be > {above:g}")
        if minval is not None and value < minval:
            raise self.error(key, f"must be >= {minval:g}")
        if maxval is not None and value > maxval:
            raise self.error(key, f"must be <= {maxval:g}")
