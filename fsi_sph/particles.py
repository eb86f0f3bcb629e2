"""Bodies as named struct-of-arrays that allocate only the fields their modules request."""

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class FieldSpec:
    """One per-particle field: ``shape`` is the per-particle shape (``()`` scalar,
    ``(2,)`` vector, ``(2, 2)`` tensor)."""

    name: str
    shape: tuple[int, ...] = ()
    dtype: type = np.float64
    init: float = 0.0


@dataclass
class Body:
    """A set of particles of one kind (``solid``, later ``fluid``, ``wall``, ``soil``).

    ``arrays`` holds contiguous arrays of leading dimension ``n``. Fields are added with
    :meth:`allocate`; asking for a field that was never requested raises ``KeyError``.
    """

    name: str
    kind: str
    n: int
    arrays: dict[str, np.ndarray] = field(default_factory=dict)

    def allocate(self, specs):
        """Allocate every field in ``specs`` not yet present (idempotent)."""
        for spec in specs:
            if spec.name not in self.arrays:
                self.arrays[spec.name] = np.full((self.n, *spec.shape), spec.init, dtype=spec.dtype)

    def select(self, keep, n_add=0):
        """Keep the rows ``keep`` (a mask) of every field and append ``n_add`` zero rows
        (a changing particle count: open boundaries)."""
        rows = np.flatnonzero(keep)
        n_keep = len(rows)
        for k, a in self.arrays.items():
            out = np.empty((n_keep + n_add, *a.shape[1:]), dtype=a.dtype)
            np.take(a, rows, axis=0, out=out[:n_keep])
            out[n_keep:] = 0
            self.arrays[k] = out
        self.n = n_keep + n_add

    def __getitem__(self, name):
        return self.arrays[name]

    def __setitem__(self, name, value):
        value = np.asarray(value)
        if value.shape[:1] != (self.n,):
            raise ValueError(f"field {name!r} of body {self.name!r} needs {self.n} rows, "
                             f"got shape {value.shape}")
        self.arrays[name] = np.ascontiguousarray(value)

    def __contains__(self, name):
        return name in self.arrays
