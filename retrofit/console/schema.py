"""The console API's request bodies, checked at the edge: one pydantic schema per body.

Strict types (a number is a JSON number, never a string), finite numbers only, ranges, and no
unknown field; ``/api/action`` is a union told apart by ``kind``. A body that does not fit is
refused with status 400 and one line naming the field, what was wrong and what is accepted, and
nothing changes. Bodies are limited in size (status 413): :data:`ACTION_BYTES` for every call,
:data:`PROGRAM_BYTES` for a program's text sent to ``/api/open``.
"""

from __future__ import annotations

from typing import Annotated, Literal, Union

from pydantic import BaseModel, ConfigDict, Field, TypeAdapter, ValidationError, model_validator

from ..errors import RetrofitError
from ..machine.config import Machine

#: largest body of an action, a run or a control call (bytes)
ACTION_BYTES = 64 * 1024
#: largest body of /api/open (a program's text, sent by the page's file picker) (bytes)
PROGRAM_BYTES = 8 * 1024 * 1024
#: feed override range (%), as 002's MFDR takes it from the operator
FEED_PCT = (1.0, 200.0)
#: rapid override range (%): never above the machine's rapid
RAPID_PCT = (1.0, 100.0)
#: pace of a run: 0 (as fast as possible) or this range (x machine time)
SPEED_RANGE = (0.05, 100.0)
#: longest MDI line (characters)
MDI_CHARS = 256


class BadRequest(RetrofitError, ValueError):
    """A request the console refuses (status 400, or ``status`` when set)."""

    def __init__(self, message: str, status: int = 400):
        super().__init__(message)
        self.status = status


class _Body(BaseModel):
    model_config = ConfigDict(strict=True, extra="forbid", allow_inf_nan=False, frozen=True)


def _pace(value: float) -> float:
    if value != 0 and not SPEED_RANGE[0] <= value <= SPEED_RANGE[1]:
        raise ValueError(f"pace {value:g}: must be 0 (as fast as possible) or {SPEED_RANGE[0]:g}.."
                         f"{SPEED_RANGE[1]:g} (x machine time)")
    return value


class RunBody(_Body):
    speed: float = 0.0

    @model_validator(mode="after")
    def _check(self):
        _pace(self.speed)
        return self


class OpenBody(_Body):
    name: str | None = Field(None, max_length=4096)
    path: str | None = Field(None, max_length=4096)
    text: str | None = None

    @model_validator(mode="after")
    def _check(self):
        if (self.name is None) == (self.path is None) or (self.text is not None and self.name is None):
            raise ValueError('expected {"name": ...} (a program the console lists), '
                             '{"path": ...} (the same) or {"name": ..., "text": ...} (an uploaded file)')
        return self


class ControlBody(_Body):
    take: bool = False


class _Plain(_Body):
    kind: Literal["stop", "hold", "resume", "answer", "home"]


class _Override(_Body):
    kind: Literal["feed", "rapid"]
    pct: float

    @model_validator(mode="after")
    def _check(self):
        lo, hi = FEED_PCT if self.kind == "feed" else RAPID_PCT
        if not lo <= self.pct <= hi:
            raise ValueError(f"{self.kind} override pct = {self.pct:g}: must be {lo:g}..{hi:g} %")
        return self


class _Speed(_Body):
    kind: Literal["speed"]
    factor: float

    @model_validator(mode="after")
    def _check(self):
        _pace(self.factor)
        return self


class _Mdi(_Body):
    kind: Literal["mdi"]
    text: str = Field(min_length=1, max_length=MDI_CHARS)


def action_schema(machine: Machine) -> TypeAdapter:
    """The schema of ``/api/action`` bodies for ``machine`` (its axes, its travel)."""
    names = tuple(a.name for a in machine.axes)
    travel = {a.name: a.max_mm - a.min_mm for a in machine.axes}

    class _Jog(_Body):
        kind: Literal["jog"]
        axis: Literal[names]                                  # type: ignore[valid-type]
        step: float

        @model_validator(mode="after")
        def _check(self):
            if not 0 < abs(self.step) <= travel[self.axis]:
                raise ValueError(f"jog step {self.step:g} mm on {self.axis}: must be non-zero and at most "
                                 f"the axis's travel, {travel[self.axis]:g} mm")
            return self

    union = Union[_Plain, _Override, _Speed, _Mdi, _Jog]
    return TypeAdapter(Annotated[union, Field(discriminator="kind")])


def parse(schema, body: bytes, what: str):
    """``body`` (JSON bytes) checked against ``schema`` (a model or a TypeAdapter); BadRequest if not."""
    try:
        if isinstance(schema, TypeAdapter):
            return schema.validate_json(body or b"null")
        return schema.model_validate_json(body or b"null")
    except ValidationError as exc:
        raise BadRequest(f"{what}: {one_line(exc)}") from None


def one_line(exc: ValidationError) -> str:
    """The first error of ``exc`` as one line: where, what, the value given."""
    err = exc.errors(include_url=False)[0]
    where = ".".join(str(p) for p in err["loc"] if not str(p).startswith("_"))
    given = err.get("input")
    shown = "" if err["type"] in ("json_invalid", "missing") or isinstance(given, dict) else f" (got {given!r:.40})"
    msg = err["msg"].replace("Value error, ", "")
    return f"{where + ': ' if where else ''}{msg}{shown}".replace("\n", " ")
