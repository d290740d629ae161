"""The one check for a frozen dataclass whose ``__init__`` is written by hand.

A few results are built many times a frame (a region, a pair, a shadow measurement, the
segmentation): their hand-written ``__init__`` stores every field in ``__dict__`` at once,
where the generated frozen one calls ``object.__setattr__`` once per field. Such a class calls
:func:`check_init_takes_fields` when its module loads, so that a field added, removed or
reordered without its ``__init__`` stops the import instead of building wrong objects.
"""

from __future__ import annotations

import inspect
from dataclasses import MISSING, fields


def check_init_takes_fields(cls: type) -> None:
    """Raise TypeError unless ``cls.__init__`` takes exactly the dataclass's fields, in
    order, with their defaults."""
    params = [(p.name, repr(p.default)) for p in inspect.signature(cls).parameters.values()]
    want = [(f.name, repr(inspect.Parameter.empty if f.default is MISSING else f.default)) for f in fields(cls)]
    if params != want:
        raise TypeError(f"{cls.__name__}.__init__ must take exactly its fields, in order, with their defaults")
