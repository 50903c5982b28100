"""Time-series recording into numpy chunks.

The loop appends one row (a plain list of floats in its columns' order: :meth:`vinecli.sim.row.Row.values`) per
record period; rows go into fixed-size chunks in blocks (memory grows with the run, nothing is
preallocated for ``max_duration_s``); :meth:`Recorder.columns_dict` returns ``{name: 1-D array}``
at the end (the missions tools write them to Parquet).
"""

from __future__ import annotations

from array import array
from typing import ClassVar

import numpy as np

__all__ = ["Recorder"]


class Recorder:
    """Rows of floats collected into fixed-size float64 chunks that are added as the run goes.

    :meth:`append` only copies the row's floats into a flat buffer; rows go into the current chunk
    in blocks of :attr:`BLOCK` (one numpy call per block instead of one per row). Memory grows with the rows
    actually recorded: ``capacity`` (the most rows the run can record) only sizes the first chunk,
    capped at :attr:`CHUNK` rows, so a long ``max_duration_s`` costs nothing up front.
    """

    BLOCK = 256
    CHUNK: ClassVar[int] = 8192

    def __init__(self, columns: list[str], capacity: int) -> None:
        self.columns = list(columns)
        self.index = {c: i for i, c in enumerate(self.columns)}
        self._first = min(max(int(capacity), 16), self.CHUNK)
        self._chunks: list[np.ndarray] = []
        self._fill = 0  # rows used in the last chunk
        self.n = 0
        self._pending = array("d")  # rows not yet in a chunk, one after the other
        self._block_values = self.BLOCK * len(self.columns)  # pending values that make a block

    @property
    def capacity(self) -> int:
        """Rows the allocated chunks can hold."""
        return sum(c.shape[0] for c in self._chunks)

    @property
    def nbytes(self) -> int:
        """Bytes held by the allocated chunks."""
        return sum(c.nbytes for c in self._chunks)

    def append(self, row: list[float]) -> None:
        """Append one row (len = number of columns)."""
        if len(row) != len(self.columns):
            raise ValueError(f"a row of {len(row)} values for {len(self.columns)} columns")
        self._pending.extend(row)
        if len(self._pending) >= self._block_values:
            self.flush()

    def flush(self) -> None:
        """Copy pending rows into the chunks (adding a chunk when the last one is full)."""
        rows = np.frombuffer(self._pending, dtype=np.float64).reshape(-1, len(self.columns))
        i = 0
        while i < len(rows):
            if not self._chunks or self._fill == self._chunks[-1].shape[0]:
                size = self._first if not self._chunks else self.CHUNK
                self._chunks.append(np.full((size, len(self.columns)), np.nan))
                self._fill = 0
            chunk = self._chunks[-1]
            k = min(len(rows) - i, chunk.shape[0] - self._fill)
            chunk[self._fill : self._fill + k] = rows[i : i + k]
            self._fill += k
            i += k
        self.n += len(rows)
        del rows  # the view pins the buffer
        self._pending = array("d")

    def columns_dict(self) -> dict[str, np.ndarray]:
        """``{column: 1-D float64 array}`` of every row recorded so far (copies)."""
        self.flush()
        used = [c if c is not self._chunks[-1] else c[: self._fill] for c in self._chunks]
        if not used:
            return {c: np.zeros(0) for c in self.columns}
        return {c: np.concatenate([u[:, i] for u in used]) for i, c in enumerate(self.columns)}
