"""argparse where a repeated option is never silently dropped: the parser class every `refimpl`
command's options are built with (refimpl.cli.parser), and its three actions: one value given twice
is an error, a repeatable option keeps every occurrence, an option of several values adds them up."""

from __future__ import annotations

import argparse


_SEEN = "_refimpl_options_seen"
"""The namespace attribute in which one parse records the single-valued options it has met."""


class _Once(argparse._StoreAction):
    """A single-valued option (``--out FILE``, ``--format mot``): a second occurrence is an error
    naming the option, never a silent replacement of the first."""

    def __call__(self, parser, namespace, values, option_string=None):
        seen = _seen(namespace)
        if self.dest in seen:
            before = _text(getattr(namespace, self.dest))
            parser.error(f"argument {'/'.join(self.option_strings)}: given twice ({before}, then {_text(values)}); "
                         "it takes one value")
        seen[self.dest] = option_string
        setattr(namespace, self.dest, values)


class _Append(argparse._AppendAction):
    """A repeatable option (``--const NAME=VALUE``): every occurrence is kept; when its values are
    ``(name, value)`` pairs, one name given twice is an error (the later would silently win)."""

    def __call__(self, parser, namespace, values, option_string=None):
        if isinstance(values, tuple) and len(values) == 2 and isinstance(values[0], str):
            for name, before in getattr(namespace, self.dest) or ():
                if name == values[0]:
                    parser.error(f"argument {'/'.join(self.option_strings)}: {name} given twice "
                                 f"({_text(before)}, then {_text(values[1])}); give it once")
        super().__call__(parser, namespace, values, option_string)


def _text(value) -> str:
    if isinstance(value, tuple):
        return ",".join(map(str, value))
    return str(value)


class _Several(argparse.Action):
    """An option of several values (``--dets A B``): a repeated occurrence adds to the list, so
    ``--dets A --dets B`` is ``--dets A B``."""

    def __call__(self, parser, namespace, values, option_string=None):
        seen = _seen(namespace)
        before = list(getattr(namespace, self.dest)) if self.dest in seen else []
        seen[self.dest] = option_string
        setattr(namespace, self.dest, before + list(values))


def _seen(namespace: argparse.Namespace) -> dict[str, str]:
    if not hasattr(namespace, _SEEN):
        setattr(namespace, _SEEN, {})
    return getattr(namespace, _SEEN)


class _Parser(argparse.ArgumentParser):
    """argparse, where an option that takes values and names no action gets :class:`_Once` (one
    value) or :class:`_Several` (``nargs`` ``+`` or ``*``), and ``append`` gets :class:`_Append`:
    a repeated option is never silently dropped.  Flags (``store_true``) may repeat (nothing is
    lost).  Subcommand parsers are of this class too."""

    def add_argument(self, *names, **kwargs):
        if names and names[0].startswith(tuple(self.prefix_chars)) and kwargs.get("action") is None:
            kwargs["action"] = _Several if kwargs.get("nargs") in ("+", "*") else _Once
        elif kwargs.get("action") == "append":
            kwargs["action"] = _Append
        return super().add_argument(*names, **kwargs)

    def parse_known_args(self, args=None, namespace=None):
        namespace, extras = super().parse_known_args(args, namespace)
        if hasattr(namespace, _SEEN):
            delattr(namespace, _SEEN)
        return namespace, extras
