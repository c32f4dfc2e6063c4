"""A checked document's tables: `table_type` makes one class per table of a schema (a
dataclass whose fields are the table's keys, each None until set), and `Table` is what they
share: attribute access for code, a read-only mapping of the keys that are set for functions
that take a table, and `as_dict` for a plain copy.

None means "not given": a TOML file has no null, so a key set to None is a key left out, and
the mapping view leaves it out too (``"width" in stroke`` is False, ``stroke.get("width")`` is
None), as the dicts the tables replace did.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import field, make_dataclass

__all__ = ["Table", "table_type"]


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
    made.__doc__ = f"The {name} table: " + ", ".join(keys) + "."
    return made
