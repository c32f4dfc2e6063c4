"""A checked document's tables: `table_type` makes one class per table of a schema (a
dataclass whose fields are the table's keys, each None until set), and `Table` is what they
share: attribute access for code, a read-only mapping of the keys that are set for functions
that take a table, and `as_dict` for a plain copy. `result_type` makes the typed results
functions return (`Result`: a dict whose declared fields are also attributes).

None means "not given": a TOML file has no null, so a key set to None is a key left out, and
the mapping view leaves it out too (``"width" in stroke`` is False, ``stroke.get("width")`` is
None), as the dicts the tables replace did.
"""

from __future__ import annotations

import sys
from collections.abc import Mapping
from dataclasses import field, make_dataclass

__all__ = ["Table", "table_type", "Result", "result_type"]


class Table(Mapping):
    """One table of a checked document; subclasses are made by `table_type`."""

    #: The table's keys, in the schema's order (set by `table_type`).
    keys_: tuple = ()

    # -- the mapping view: the keys that are set --------------------------------------------------
    def __getitem__(self, key):
        value = getattr(self, key, None) if key in self.keys_ else None
        if value is None:
            raise KeyError(key)
        return value

    def __iter__(self):
        return (key for key in self.keys_ if getattr(self, key) is not None)

    def __len__(self):
        return sum(1 for _ in self)

    def given(self, *keys):
        """Those of ``keys`` that are set, in the order given."""
        return [key for key in keys if getattr(self, key) is not None]

    def as_dict(self) -> dict:
        """A plain dict of the keys that are set, nested tables and lists of tables as dicts."""
        return {key: _plain(getattr(self, key)) for key in self}


def _plain(value):
    if isinstance(value, Table):
        return value.as_dict()
    if isinstance(value, list):
        return [_plain(item) for item in value]
    return value


def table_type(name, keys, base=Table):
    """A `Table` class named ``name`` whose fields are ``keys`` (each defaulting to None)."""
    keys = tuple(keys)
    made = make_dataclass(
        name,
        [(key, object, field(default=None)) for key in keys],
        bases=(base,),
        eq=False,  # (a table's arrays have no truth value: tables compare as mappings)
    )
    made.keys_ = keys
    made.__module__ = _caller_module()  # (where pickle finds it)
    made.__doc__ = f"The {name} table: " + ", ".join(keys) + "."
    return made


class Result(dict):
    """A result a function returns (statistics, energies): a dict, so it prints, compares and
    goes to JSON as one, whose fields are also attributes (``sim.stats.phases``); subclasses
    are made by `result_type`, which declares the fields."""

    __slots__ = ()
    #: The fields, in order (set by `result_type`).
    fields_: tuple = ()


def _field_property(key):
    def read(self):
        try:
            return self[key]
        except KeyError:
            return None  # (an optional field the result leaves out)

    return property(read, doc=f"``{key}``")


def result_type(name, keys, doc):
    """A `Result` class named ``name`` with the attributes ``keys`` (None when absent)."""
    keys = tuple(keys)
    namespace = {key: _field_property(key) for key in keys}
    namespace.update(__slots__=(), fields_=keys, __doc__=doc, __module__=_caller_module())
    return type(name, (Result,), namespace)


def _caller_module():
    """The module that called the type factory (two frames up), as collections.namedtuple
    finds it."""
    return sys._getframe(2).f_globals.get("__name__", __name__)
