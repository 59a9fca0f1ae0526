"""Options declared once: each field of an options dataclass carries its one-line help and
its rule (:func:`option`), and the checks of the class (:func:`check_fields`), the
command line's flags (:func:`add_flags`) and the keys of ``session.toml``
(:func:`from_value`) are made from them."""

from __future__ import annotations

import argparse
import math
import types
import typing
from collections.abc import Callable
from dataclasses import MISSING, Field, dataclass, field, fields, replace

from hullcap.errors import OptionsError

__all__ = ["AT_LEAST_ONE", "BOOL", "CAMERA_NAMES", "FRACTION", "NON_NEGATIVE", "NON_NEGATIVE_INT", "POSITIVE",
           "VOLUME", "Rule", "add_flags", "check_fields", "flag_fields", "flag_name", "from_arguments", "from_value",
           "one_of", "option", "or_none", "reference_table"]


@dataclass(frozen=True)
class Rule:
    """What a setting's value must be: `want` says it in words (``"a positive number"``),
    `holds` tests a value."""

    want: str
    holds: Callable[[object], bool]

    def check(self, name: str, value, where: str = "", error: type[Exception] = OptionsError) -> None:
        """`error` (an OptionsError) naming `name` (in `where`, when given) unless `value`
        holds."""
        if not self.holds(value):
            raise error(f"{where}{': ' if where else ''}{name} must be {self.want}, got {value!r}")


def _number(v) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


BOOL = Rule("true or false", lambda v: isinstance(v, bool))
POSITIVE = Rule("a positive number", lambda v: _number(v) and v > 0)
NON_NEGATIVE = Rule("a number >= 0", lambda v: _number(v) and v >= 0)
FRACTION = Rule("a fraction in (0, 1]", lambda v: _number(v) and 0 < v <= 1)
AT_LEAST_ONE = Rule("a whole number, at least 1", lambda v: isinstance(v, int) and not isinstance(v, bool) and v >= 1)
NON_NEGATIVE_INT = Rule("a whole number >= 0", lambda v: isinstance(v, int) and not isinstance(v, bool) and v >= 0)
VOLUME = Rule("six numbers x0, y0, z0, x1, y1, z1 in metres",
              lambda v: isinstance(v, tuple | list) and len(v) == 6 and all(_number(x) for x in v))
CAMERA_NAMES = Rule('a list of camera names (cam0,cam2 on the command line)',
                    lambda v: isinstance(v, tuple | list) and all(isinstance(x, str) and x for x in v))


def one_of(*choices: str) -> Rule:
    """One of `choices`."""
    return Rule(" or ".join(repr(c) for c in choices), lambda v: v in choices)


def or_none(rule: Rule) -> Rule:
    """`rule`, or None (an option left unset: said as `rule` alone, since a file or a
    command line leaves it out rather than naming None)."""
    return Rule(rule.want, lambda v: v is None or rule.holds(v))


def option(default=MISSING, *, help: str, rule: Rule | None = None, factory=MISSING, metavar: str | None = None,
           flag: bool = False) -> Field:
    """A field of an options dataclass: its `default` (or `factory`), its one-line `help`,
    the `rule` its value must follow, and with `flag` a command-line flag and a key of
    ``session.toml`` (``--voxel-size``, ``voxel_size``; a bool whose default is true is
    turned off by ``--no-<name>``)."""
    metadata = {"help": help, "rule": rule, "metavar": metavar, "flag": flag}
    if factory is not MISSING:
        return field(default_factory=factory, metadata=metadata)
    return field(default=default, metadata=metadata)


def check_fields(options) -> None:
    """OptionsError naming the first field of `options` that breaks its rule."""
    for f in fields(options):
        rule = f.metadata.get("rule")
        if rule is not None:
            rule.check(f.name, getattr(options, f.name))


def flag_fields(cls) -> list[Field]:
    """The fields of options class `cls` that are flags and ``session.toml`` keys."""
    return [f for f in fields(cls) if f.metadata.get("flag")]


def flag_name(f: Field) -> str:
    """The command-line flag of field `f`."""
    name = f.name.replace("_", "-")
    return f"--no-{name}" if f.default is True else f"--{name}"


def _default(f: Field):
    return f.default_factory() if f.default is MISSING else f.default


def _base_type(f: Field, cls) -> tuple[type, type | None]:
    """The type of `f`'s values with None taken away (bool, int, float, str or tuple), and
    for a tuple the type of its items."""
    hint = typing.get_type_hints(cls)[f.name]
    if isinstance(hint, types.UnionType) or typing.get_origin(hint) is typing.Union:
        hint = next(a for a in typing.get_args(hint) if a is not type(None))
    if typing.get_origin(hint) is tuple:
        return tuple, typing.get_args(hint)[0]
    return hint, None


def from_value(cls, name: str, value, where: str):
    """`value` (from a TOML file) of `cls`'s field `name` as the field holds it, checked by
    its rule (an error names `where` and `name`)."""
    f = next(f for f in fields(cls) if f.name == name)
    kind, _ = _base_type(f, cls)
    if kind is float and _number(value):
        value = float(value)
    elif kind is tuple and isinstance(value, list):
        value = tuple(value)
    rule = f.metadata.get("rule")
    if rule is not None:
        rule.check(name, value, where)
    return value


def _argument_type(f: Field, cls) -> Callable[[str], object]:
    """The function that turns the text of `f`'s flag into its value, checked."""
    kind, item = _base_type(f, cls)
    rule = f.metadata.get("rule")

    def parse(text: str):
        try:
            if kind is tuple:
                value = tuple(item(x.strip()) for x in text.split(","))
            else:
                value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be {rule.want if rule else kind.__name__}, got {text!r}") from None
        if rule is not None and not rule.holds(value):
            raise argparse.ArgumentTypeError(f"must be {rule.want}, got {text!r}")
        return value
    return parse


GIVEN = "_flags_given"
"""The attribute of a parsed namespace holding the flags its command line gave (by field name)."""


class _Given(argparse.Action):
    """Stores a flag's value (or, with `const`, that constant) and records that it was given."""

    def __init__(self, option_strings, dest, const=None, nargs=None, **kwargs):
        super().__init__(option_strings, dest, nargs=0 if const is not None else nargs, const=const, **kwargs)

    def __call__(self, parser, namespace, values, option_string=None):
        setattr(namespace, self.dest, self.const if self.const is not None else values)
        given = getattr(namespace, GIVEN, set())
        setattr(namespace, GIVEN, given | {self.dest})


def add_flags(parser: argparse.ArgumentParser, cls, names: list[str] | None = None) -> None:
    """Add to `parser` the flags of `cls`'s flag fields (or of the fields `names`), with
    their help and default; the namespace records which were given (:func:`from_arguments`)."""
    chosen = flag_fields(cls) if names is None else [f for f in fields(cls) if f.name in names]
    for f in chosen:
        default, help = _default(f), f.metadata["help"]
        if isinstance(default, bool):
            parser.add_argument(flag_name(f), dest=f.name, action=_Given, const=not default, default=default,
                                help=f"{help} (on by default: this turns it off)" if default else help)
            continue
        said = default is None or default == () or "default" in help
        shown = "" if said else f" (default {default})"
        parser.add_argument(flag_name(f), dest=f.name, action=_Given, type=_argument_type(f, cls), default=default,
                            metavar=f.metadata.get("metavar") or f.name.upper(), help=f"{help}{shown}")


def from_arguments(cls, args: argparse.Namespace, base=None, **extra):
    """`cls` with the flag fields the command line `args` gave over `base` (None: the
    defaults; a flag the command line did not give keeps `base`'s value), and `extra`."""
    if base is None:
        given = {f.name: getattr(args, f.name) for f in flag_fields(cls) if hasattr(args, f.name)}
        return cls(**given, **extra)
    named = getattr(args, GIVEN, set())
    return replace(base, **{f.name: getattr(args, f.name) for f in flag_fields(cls) if f.name in named}, **extra)


def reference_table(cls, every: bool = False) -> str:
    """A Markdown table of `cls`'s flag fields (or, with `every`, all its fields): name,
    default, what it is."""
    rows = ["| option | default | |", "|---|---|---|"]
    for f in fields(cls) if every else flag_fields(cls):
        if "help" not in f.metadata:
            continue
        default = _default(f)
        if isinstance(default, bool):
            shown = str(default).lower()
        elif default is None or default == ():
            shown = "none"
        elif isinstance(default, int | float | str | tuple):
            shown = f"`{default!r}`".replace("'", '"')
        else:
            shown = f"a `{type(default).__name__}`"
        rows.append(f"| `{f.name}` | {shown} | {f.metadata['help']} |")
    return "\n".join(rows)
