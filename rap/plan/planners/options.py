"""Planner options as data: a planning method declares its options once, in a frozen dataclass.

OMPL's planners declare their parameters once (``declareParam``) and their capabilities in
``PlannerSpecs``. Here a method is a subclass of ``PlannerOptions``::

    @register                                   # rap.plan.methods.register
    @dataclass(frozen=True)
    class SearchOptions(PlannerOptions):
        method: ClassVar[str] = "search"        # its name: plan --method, the service's "method"
        needs_model: ClassVar[bool] = True      # it scores operations with the CNN
        planner: ClassVar[type] = SearchPlanner  # built with the options as keywords
        simulations: int = option(int, 0, low=0, code="s", code_name="N",
                                  help="Method {method}: simulations to spend while planning")

Each ``option`` states its type (``int`` or ``float``), default, range (``low``, ``high``;
``low_open``: ``low`` itself excluded), help text (a template: ``{method}`` and the names of the
method's other options in braces, which a reader replaces by its own names for them, e.g. flags),
and its letter in experiment method names (``code``, with ``code_name`` the placeholder in
messages; ``percent``: written as an integer percentage, ``p90`` for 0.9). ``cli``/``service``:
whether ``rap-farm plan`` has a flag for it and the planning service accepts it.

Everything that reads options reads them here:

* constructing the dataclass validates every value (``ParameterError`` naming the option):
  this is the one place options are checked; ``of(**given)`` keeps the given values (None: the
  default) of the options the method declares;
* ``rap-farm plan`` makes its flags from the declarations (``Option.help_text``, ranges);
* the planning service reads a request's ``options`` by them (``rap.serve.api``);
* the experiment's method names (``rap-k2-p90``, ``search-s200-o10``, ``rap-paper`` from
  ``presets``) are read by ``from_table_name`` and written by ``table_name``.

No planner is imported here (``rap.plan.methods`` holds the shipped methods). No ray, no torch.
"""

from __future__ import annotations

import numbers
import string
from dataclasses import dataclass, field, fields, replace
from typing import Any, Callable, ClassVar

from rap.errors import ParameterError

__all__ = ["Option", "option", "PlannerOptions"]


@dataclass(frozen=True)
class Option:
    """One option of a planning method (module doc). ``name`` is the planner's keyword."""

    name: str
    kind: type  # int or float
    default: Any
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    help: str = ""  # template: {method}, {other option}
    default_help: str = ""  # a default of None in words; else a note after the value
    noun: str = ""  # a value in messages ("a probability"); default: an integer / a number
    code: str = ""  # its letter in experiment method names
    code_name: str = ""  # the letter's placeholder in messages (K, P)
    percent: bool = False  # the table name writes 100 x the value, as an integer
    cli: bool = True  # rap-farm plan has a flag for it
    service: bool = True  # the planning service accepts it

    def describe(self) -> str:
        """What a valid value is: ``a score in (0, 1]``, ``an integer >= 1``."""
        noun = self.noun or ("an integer" if self.kind is int else "a number")
        if self.high is not None:
            return f"{noun} in {'(' if self.low_open else '['}{self.low:g}, {self.high:g}]"
        if self.low is not None:
            return f"{noun} {'>' if self.low_open else '>='} {self.low:g}"
        return noun

    def check(self, value) -> None:
        """Raise ``ParameterError`` (this option's name, ``value``, ``describe()``) unless
        ``value`` is valid: None where the default is None, else of the option's type (an int
        where it is ``int``) within its range."""
        if value is None and self.default is None:
            return
        number = isinstance(value, numbers.Real) and not isinstance(value, bool)
        if (not number or (self.kind is int and not isinstance(value, numbers.Integral))
                or (self.low is not None and (value <= self.low if self.low_open
                                              else value < self.low))
                or (self.high is not None and value > self.high)):
            raise ParameterError(self.name, value, f"choose {self.describe()}")

    def default_text(self) -> str:
        """The default in words: ``0.9; the paper: 0.5``, ``every candidate``, ``8``."""
        if self.default is None:
            return self.default_help
        text = f"{self.default:g}" if isinstance(self.default, float) else str(self.default)
        return f"{text}; {self.default_help}" if self.default_help else text

    def help_text(self, method: str, name: Callable[[str], str] = str) -> str:
        """The help with its default, the options it mentions called ``name(option)``, e.g.
        ``Method search: simulations to spend while planning [default: 0].``"""
        mentioned = {f for _, f, _, _ in string.Formatter().parse(self.help) if f}
        body = self.help.format(**{f: name(f) for f in mentioned - {"method"}}, method=method)
        return f"{body} [default: {self.default_text()}]."

    def table_range(self) -> str:
        """The range in an experiment method name's terms: ``1..100`` (percent), ``>= 1``."""
        scale = 100 if self.percent else 1
        low = round(self.low * scale) + (1 if self.low_open else 0)
        if self.high is None:
            return f"be >= {low}"
        return f"lie in {low}..{round(self.high * scale)}"


def option(kind: type, default, **spec) -> Any:
    """A dataclass field of a ``PlannerOptions`` subclass declaring an ``Option`` (module doc)."""
    return field(default=default, metadata={"option": Option("", kind, default, **spec)})


@dataclass(frozen=True)
class PlannerOptions:
    """A planning method's options, validated on construction; subclasses declare them with
    ``option``. Class attributes: ``method`` (its name, without ``-``), ``planner`` (the planner
    class, which ``build`` calls with the options as keywords), ``needs_model`` (scores with the
    CNN), ``summary`` (a line for ``--method``'s help, or empty), ``presets`` (table-name suffix
    -> options, e.g. ``{"paper": {...}}``)."""

    method: ClassVar[str] = ""
    planner: ClassVar[Callable | None] = None
    needs_model: ClassVar[bool] = False
    summary: ClassVar[str] = ""
    presets: ClassVar[dict] = {}

    def __post_init__(self):
        for opt in self.declared():
            opt.check(getattr(self, opt.name))

    @classmethod
    def declared(cls) -> tuple[Option, ...]:
        """The options, in declaration order."""
        return tuple(replace(f.metadata["option"], name=f.name) for f in fields(cls)
                     if "option" in f.metadata)

    @classmethod
    def of(cls, **given) -> PlannerOptions:
        """The options with the ``given`` values of those this method declares; None, and names
        it does not declare, leave the default."""
        names = {o.name for o in cls.declared()}
        return cls(**{k: v for k, v in given.items() if v is not None and k in names})

    def build(self):
        """The planner (a ``rap.plan.planners.base.Planner``) with these options:
        ``planner(self)``; a method whose planner is made otherwise overrides this."""
        if self.planner is None:
            raise TypeError(f"{type(self).__name__} declares no planner class and does not "
                            f"override build()")
        return self.planner(self)

    # -- experiment method names ----------------------------------------------------------------
    @classmethod
    def table_syntax(cls) -> str:
        """How this method's options are written in a method name, for messages."""
        coded = [o for o in cls.declared() if o.code]
        if not coded:
            return f"{cls.method} takes no options"
        each = ", ".join(f"-{o.code}{o.code_name} ({o.name}"
                         + (f", {o.code_name} percent)" if o.percent else ")") for o in coded)
        names = [cls.method + "".join(f"-{o.code}{o.code_name}" for o in coded)]
        names += [f"{cls.method}-{p}" for p in cls.presets]
        return f"{cls.method} options are {each}, as in {' or '.join(names)}"

    @classmethod
    def from_table_name(cls, name: str, **base) -> PlannerOptions:
        """The options named by ``name`` (``rap``, ``rap-k2-p90``, ``rap-paper``), starting from
        ``base`` (values of None and options not declared ignored); ``ParameterError`` for
        parameter ``method`` when ``name`` is malformed or a value is out of range."""
        head, *parts = name.split("-")
        if head != cls.method:
            raise ParameterError("method", name, f"not a name of method {cls.method!r}")
        if len(parts) == 1 and parts[0] in cls.presets:
            return cls.of(**{**base, **cls.presets[parts[0]]})
        coded = {o.code: o for o in cls.declared() if o.code}
        values: dict = {}
        for part in parts:
            opt = coded.get(part[:1])
            if opt is None or not part[1:].isdigit() or opt.name in values:
                raise ParameterError("method", name, cls.table_syntax())
            values[opt.name] = int(part[1:]) / 100 if opt.percent else int(part[1:])
        try:
            return cls.of(**{**base, **values})
        except ParameterError as exc:
            bad = next((o for o in coded.values() if o.name == exc.parameter), None)
            if bad is None:
                raise
            raise ParameterError("method", name, f"{bad.code_name} must {bad.table_range()}") \
                from None

    def table_name(self) -> str:
        """The method name of these options in experiment tables (``rap-k2-p90``): the options
        that differ from their defaults by their codes; a preset's name where one matches.
        ``ValueError`` where an option that differs has no code or is not a whole percentage."""
        for suffix, values in self.presets.items():
            if self == self.of(**values):
                return f"{self.method}-{suffix}"
        out = self.method
        for o in self.declared():
            value = getattr(self, o.name)
            if value == o.default:
                continue
            shown = round(value * 100) if o.percent else value
            if not o.code or not isinstance(shown, int) or (o.percent and shown / 100 != value):
                raise ValueError(f"{o.name}={value!r} has no experiment method name")
            out += f"-{o.code}{shown}"
        return out
