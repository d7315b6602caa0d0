"""Estimator options: text to typed values, and a description of each option for people.

Options come as Python values (a study file, code) or as text (``--option key=value`` on
the command line). Text is parsed as a TOML value (``450``, ``0.5``, ``true``,
``[50, 150, 100, 150]``, ``"noise"``), else kept as the plain string; the value is then
checked against the dataclass field's type hint (:func:`coerce`). Every error is one
line naming the estimator and the option.

:func:`describe_options` lists an estimator's options (type, default and the first
sentence of the option's entry in the class docstring's ``Options``, ``Attributes`` or
``Parameters`` section) for ``aeroid methods --options NAME``.

A field with the metadata :data:`NOT_AN_OPTION` is set by code, not by users (output-error's
``start_parameters``, the consider re-fits' warm start): :func:`options_of` leaves it
out, so it is no option (``options()``, ``option_names()``, ``from_options``, this list).
"""

from __future__ import annotations

import dataclasses
import inspect
import re
import tomllib
import types
import typing
from dataclasses import dataclass
from typing import Any

from aeroid.errors import EstimatorError

__all__ = ["NOT_AN_OPTION", "OptionInfo", "coerce", "describe_options", "options_of",
           "parse_value", "type_name"]

#: ``dataclasses.field(metadata=NOT_AN_OPTION)``: an estimator's field that is no option.
NOT_AN_OPTION = types.MappingProxyType({"option": False})


def options_of(estimator: Any) -> tuple[dataclasses.Field, ...]:
    """Return the fields of an estimator (class or instance) that are options."""
    return tuple(f for f in dataclasses.fields(estimator) if f.metadata.get("option", True))

_SECTIONS = ("Options", "Attributes", "Parameters")
_TRUE = ("true", "yes", "on", "1")
_FALSE = ("false", "no", "off", "0")


def parse_value(text: str) -> Any:
    """Parse an option value given as text: a TOML value, else the plain string."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def coerce(name: str, value: Any, hint: Any, owner: str) -> Any:
    """Check/convert ``value`` against a simple type hint; one-line error if it does not fit.

    Raises
    ------
    EstimatorError
        ``OWNER: option NAME expects ..., got VALUE``.
    """
    origin = typing.get_origin(hint)
    if origin is typing.Union or isinstance(hint, types.UnionType):
        args = typing.get_args(hint)
        is_none = value is None or (isinstance(value, str) and value.lower() == "none")
        if is_none and type(None) in args:
            return None
        errors = []
        for arg in args:
            if arg is type(None):
                continue
            try:
                return coerce(name, value, arg, owner)
            except EstimatorError as exc:
                errors.append(str(exc))
        raise EstimatorError(errors[0] if errors else f"{owner}: bad value for {name}")
    if origin is typing.Literal:
        allowed = typing.get_args(hint)
        if value not in allowed:
            raise EstimatorError(
                f"{owner}: option {name}={value!r} not one of {', '.join(map(repr, allowed))}"
            )
        return value
    if hint is bool:
        if isinstance(value, bool):
            return value
        if isinstance(value, str) and value.lower() in _TRUE + _FALSE:
            return value.lower() in _TRUE
        raise EstimatorError(f"{owner}: option {name} expects true/false, got {value!r}")
    if hint is int:
        if isinstance(value, int) and not isinstance(value, bool):
            return value
        raise EstimatorError(f"{owner}: option {name} expects an integer, got {value!r}")
    if hint is float:
        if isinstance(value, int | float) and not isinstance(value, bool):
            return float(value)
        raise EstimatorError(f"{owner}: option {name} expects a number, got {value!r}")
    if hint is str:
        return str(value)
    if origin in (tuple, list):
        if not isinstance(value, list | tuple):
            raise EstimatorError(f"{owner}: option {name} expects a list, got {value!r}")
        item_types = [a for a in typing.get_args(hint) if a is not Ellipsis]
        items = ([coerce(name, v, item_types[0], owner) for v in value]
                 if len(item_types) == 1 else list(value))
        return tuple(items) if origin is tuple else items
    return value


def type_name(hint: Any) -> str:
    """Return a type hint in words: ``int``, ``{noise, relative}``, ``list of int or none``."""
    origin = typing.get_origin(hint)
    if origin is typing.Union or isinstance(hint, types.UnionType):
        return " or ".join(type_name(a) for a in typing.get_args(hint))
    if origin is typing.Literal:
        return "{" + ", ".join(str(a) for a in typing.get_args(hint)) + "}"
    if hint is type(None):
        return "none"
    if origin in (tuple, list):
        args = [a for a in typing.get_args(hint) if a is not Ellipsis]
        return "list" + (f" of {type_name(args[0])}" if len(args) == 1 else "")
    return getattr(hint, "__name__", str(hint))


@dataclass(frozen=True)
class OptionInfo:
    """One option of an estimator, for people.

    Attributes
    ----------
    name : str
    type : str
        The type in words (:func:`type_name`).
    default : Any
    description : str
        First sentence of the option's docstring entry ("" when undocumented).
    """

    name: str
    type: str
    default: Any
    description: str


def _plain(text: str) -> str:
    """Return docstring text without reST markup (roles, double backticks)."""
    text = re.sub(r":\w+:`~?([^`]+)`", r"\1", text)
    return text.replace("``", "")


def _first_sentence(lines: list[str]) -> str:
    text = _plain(" ".join(" ".join(lines).split()))
    match = re.search(r"(?<=[.!?])\s+(?=[A-Z(\"'`])", text)
    return text[: match.start()] if match else text


def _sections(lines: list[str]) -> list[tuple[str, list[str]]]:
    """Split docstring lines into numpydoc sections: (title, body lines)."""
    heads = [i for i in range(len(lines) - 1)
             if lines[i].strip() and set(lines[i + 1].strip()) == {"-"}]
    ends = [*heads[1:], len(lines)][: len(heads)]
    return [(lines[i].strip(), lines[i + 2:end]) for i, end in zip(heads, ends, strict=True)]


def _docstring_entries(doc: str) -> dict[str, str]:
    """Return ``{option name: first sentence}`` from a numpydoc options section."""
    entries: dict[str, str] = {}
    for title, body in _sections(inspect.cleandoc(doc).splitlines()):
        if title not in _SECTIONS:
            continue
        names: list[str] = []
        text: list[str] = []
        paragraph_done = False
        for line in [*body, "end-of-section"]:
            if line.strip() and not line[0].isspace():  # a new entry: "a, b : type"
                for name in names:
                    entries.setdefault(name, _first_sentence(text))
                names = [n.strip() for n in line.split(":")[0].split(",") if n.strip()]
                text, paragraph_done = [], False
            elif not line.strip():
                paragraph_done = bool(text)
            elif not paragraph_done:
                text.append(line.strip())
    return entries


def describe_options(cls: type) -> list[OptionInfo]:
    """Return every option of an estimator class: name, type, default and description.

    The description is the first sentence of the option's entry in the docstring of the
    class or of its first base class that documents it (sections ``Options``,
    ``Attributes`` or ``Parameters``, numpydoc layout).
    """
    docs: dict[str, str] = {}
    for klass in cls.__mro__:
        for key, text in _docstring_entries(klass.__doc__ or "").items():
            docs.setdefault(key, text)
    hints = typing.get_type_hints(cls)
    out = []
    for f in options_of(cls):
        if f.default is not dataclasses.MISSING:
            default = f.default
        elif f.default_factory is not dataclasses.MISSING:
            default = f.default_factory()
        else:
            default = None
        out.append(OptionInfo(f.name, type_name(hints.get(f.name, Any)), default,
                              docs.get(f.name, "")))
    return out
